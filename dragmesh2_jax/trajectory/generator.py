"""Geometry-guided reference trajectories (paper §3.3, Appendix B, Algorithm 1), executed in MuJoCo physics.

The plan is a sequence of 51-d hand PD targets, one per frame (one 1/60 s control step = ``substeps``
physics steps): approach (wrist from x_pre = x_w + delta n to x_w, fingers open -> pre-shape), grasp
(wrist fixed, fingers pre-shape -> grasp), drag (prismatic: the wrist translates d along the opening
direction; revolute: the palm target rotates by theta about the joint axis and origin, the wrist rotating in
step), release (fingers open, wrist retracts along the final normal). The plan runs in the C engine with the
hand tracking it through its PD actuators; the object moves only through contact. Every frame records the
simulated state, so ``joint_positions`` is what contact achieved.

If a grasp placement fails the quality gate, a few alternative palm placements are tried in order
(``GeneratorParams.placements``); the header records which one passed and every attempt. Of the placements that
pass, the first whose hand *holds* the handle at the drag start is kept (``grip``: the hand presses on the handle
with at least ``min_grip_force`` in the state the task resets to, where every PD target equals the pose). A
fingertip grasp that merely touches the bar passes the rest of the gate, because the scripted drag closes the
fingers around it as it pulls, but a policy, whose zero action leaves the fingers where they are, loses such a
handle to undirected exploration within a few dozen steps and learns not to pull (RESULTS.md §1, the drawer
regression). When no passing placement grips, the first that passes is kept and the header says so.

Beyond the paper, the placements may instead be ranked by the load they hold (``GeneratorParams.placement_choice``
"holds"): every passing placement's expert drag is replayed from the task's reset state at each of ``HOLD_DAMPINGS`` x
the nominal damping, and the one that still opens the part past q_done at the highest is kept (then the gripping one,
then the first): the first gripping placement lets go of doors under load that another holds (RESULTS.md, the suite).

A grasp may be seated (``GeneratorParams.seat_depth``): the planned pose lies inside the handle, so each placement's
plan is executed once, the hand taken where the handle stopped it (moved out where it is deeper than the seat depth:
``grasp.seat``), and the plan executed again with the wrist's target there and the fingers' ``grip_closure`` past it.
Where no seated placement passes the gate, the planned ones (executed on the way) are ranked instead; ranked by the
load they hold, the planned ones are ranked beside the seated ones, and a planned one is kept only where it holds past
a higher damping than every seated one (a seated grasp pulls less where nothing resists: it wins ties). The header's
``generator.seated`` says which was kept.
"""

from __future__ import annotations

import contextlib
import itertools
import time
import warnings
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Literal

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from dragmesh2_jax.assets import hand as hand_lib
from dragmesh2_jax.assets.gapartnet import GAPartNetObject
from dragmesh2_jax.assets.target import opening_direction
from dragmesh2_jax.assets.urdf import axis_angle_matrix
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.io import cache_dir, hash_files, object_hash
from dragmesh2_jax.physics import contacts
from dragmesh2_jax.scene import RESET_SETTLE_SUBSTEPS, Scene, SceneConfig, build_scene, contact_depth
from dragmesh2_jax.trajectory import grasp
from dragmesh2_jax.trajectory.schema import Frame, Trajectory, read_trajectory, write_trajectory

#: Every 2 pi shift of three Euler angles (-1, 0, +1 turns each), in the order the nearest one is picked by.
EULER_SHIFTS = 2 * np.pi * np.array(list(itertools.product((-1, 0, 1), repeat=3)), dtype=np.float64)
# 1.1: the grip at the drag start picks among the passing placements; 1.2: seated grasps; 1.3: a seated grasp falls
# back to the planned placements where no seated one passes the gate; 1.4: ranked by the load they hold, a planned
# placement is kept where it holds more than every seated one
GENERATOR_VERSION = "1.4"
#: The damping multipliers a placement's drag is executed at to rank the placements by the load they hold (the
#: recipe's training range, an octave apart, and one beyond it), in order: ranking stops at the first not opened.
HOLD_DAMPINGS = (2.0, 4.0, 8.0, 16.0)
#: The seated grasp's depth (m): deeper than this, the hand is moved out of the handle (``grasp.seat``); under the
#: hand's object contacts the grasp the handle stopped is 0.7-1.1 mm deep on the packaged objects and 45261, so it
#: stays where the handle stopped it.
SEAT_DEPTH = 0.002


@dataclass(frozen=True)
class GeneratorParams:
    """Phase lengths (frames of 1/60 s), offsets (m), drag extent, and the quality gate.

    ``drag_distance``/``drag_angle`` default to 80% of the joint range, capped at 0.30 m / 60 deg (the
    reference's 0.5 m and 60 deg at 0.4 scale); ``delta`` is the pre-grasp offset along the normal."""

    approach_frames: int = 45
    grasp_frames: int = 40
    drag_frames: int = 180
    release_frames: int = 45
    settle_frames: int = 5
    delta: float = 0.08
    drag_distance: float | None = None
    drag_angle: float | None = None
    drag_fraction: float = 0.8
    max_drag_distance: float = 0.30
    max_drag_angle: float = float(np.radians(60.0))
    retract: float = 0.10
    substeps: int = 4  # physics steps per frame (dt = 1/240 s -> 60 Hz frames)
    placements: tuple[grasp.GraspParams, ...] = (
        grasp.GraspParams(),
        grasp.GraspParams(palm_clearance=0.015, normal_offset=0.02),
        grasp.GraspParams(palm_clearance=0.03, normal_offset=0.05),
        grasp.GraspParams(palm_clearance=0.015, normal_offset=0.033, flip=True),
    )
    # quality gate
    min_open_fraction: float = 0.5  # the joint must follow at least this much of the planned drag
    max_penetration: float = 0.015  # m
    limit_tolerance: float = 0.02  # rad or m beyond the hand's joint limits
    # the task's detachment rule (TaskConfig.d_detach): once the palm is this near the handle in the drag, it stays
    # so until the joint passes q_done, so that tracking the trajectory from the task's reset is never detached
    max_palm_distance: float = 0.10  # m
    # grip at the drag start (preferred among passing placements): the normal force of the hand's contacts in the
    # handle's box, grown by ``grip_margin``, after the task's reset settle. Measured: a fingertip grasp that rests
    # on the bar 3.7 N; the grasps policies learn from 30-220 N (RESULTS.md §1)
    min_grip_force: float = 10.0  # N
    grip_margin: float = 0.005  # m
    # the seated grasp: the planned grasp executed, the hand then moved out of the handle where it is deeper than
    # ``seat_depth`` (``grasp.seat``), and the plan executed again to that seat with finger targets ``grip_closure``
    # rad past it: the planned pose lies inside the handle (its wrist up to 33 mm, its fingers up to 1 rad past where
    # the handle stops them), so the drives press the hand into it with up to 100 N (RESULTS.md, penetration);
    # None: that planned grasp (generator 1.1), the default: the seated one does not yet open small handles
    seat_depth: float | None = None  # m; SEAT_DEPTH seats it
    grip_closure: float = 0.04  # rad
    # which passing placement is kept: "first", the first that grips; "holds", the one whose drag opens the part at
    # the highest of HOLD_DAMPINGS (``holds``), replayed over an episode of ``hold_steps`` control steps
    placement_choice: Literal["first", "holds"] = "first"
    hold_steps: int = 300

    def __post_init__(self):
        for k in ("approach_frames", "grasp_frames", "drag_frames", "release_frames", "substeps"):
            if getattr(self, k) < 1:
                raise DragMeshError(f"generator parameter {k} must be >= 1, got {getattr(self, k)}")
        if self.delta < 0 or self.retract < 0:
            raise DragMeshError("generator offsets delta and retract must be >= 0")


@dataclass
class Plan:
    phases: list[str] = field(default_factory=list)
    steps: list[int] = field(default_factory=list)
    targets: list[np.ndarray] = field(default_factory=list)

    def add(self, phase: str, step: int, q: np.ndarray) -> None:
        self.phases.append(phase)
        self.steps.append(step)
        self.targets.append(np.asarray(q, dtype=np.float64))


def continuous_euler(R: np.ndarray, prev: np.ndarray | None, limit: float = np.pi) -> np.ndarray:
    """Intrinsic XYZ angles of R. Of the two equivalent solutions and their 2 pi shifts, keep those inside the
    wrist limits (+-``limit``) and take the one nearest ``prev``, so the wrist PD target never jumps."""
    with warnings.catch_warnings():  # a palm facing along x (the wrap on a door) is the gimbal lock: third angle 0
        warnings.simplefilter("ignore", UserWarning)
        a = Rotation.from_matrix(R).as_euler("XYZ")
    b = np.array([a[0] + np.pi, np.pi - a[1], a[2] + np.pi])
    cands = (np.stack([a, b])[:, None, :] + EULER_SHIFTS).reshape(-1, 3)
    inside = np.all(np.abs(cands) <= limit + 1e-9, axis=1)
    pool = cands[inside] if inside.any() else cands
    ref = prev if prev is not None else np.zeros(3)
    return pool[np.argmin(np.abs(pool - ref).sum(axis=1))]


def drag_extent(scene: Scene, params: GeneratorParams) -> float:
    lo, hi = scene.ids.target_range
    if scene.ids.target_is_revolute:
        return params.drag_angle if params.drag_angle is not None else min(
            params.max_drag_angle, params.drag_fraction * (hi - lo))
    return params.drag_distance if params.drag_distance is not None else min(
        params.max_drag_distance, params.drag_fraction * (hi - lo))


def make_plan(scene: Scene, params: GeneratorParams, placement: grasp.GraspParams,
              seated: np.ndarray | None = None) -> Plan:
    """The hand PD targets of every frame (Algorithm 1), in world coordinates; ``seated``: the grasp where the hand
    touches the handle (``grasp.seat``), which the wrist goes to and the fingers grip just past
    (``params.grip_closure``), instead of the planned pose that the handle stops short."""
    obj, h = scene.obj, scene.handle
    t = obj.target
    s, pos = scene.config.scale, np.asarray(scene.config.object_pos)
    pivot = pos + s * t.joint.origin
    axis = t.joint.axis / np.linalg.norm(t.joint.axis)
    open_dir = opening_direction(t.part, t.joint, t.handle.centre)
    away = None
    if t.joint.is_revolute:
        away = h.centre - pivot
        away = away - (away @ axis) * axis
        away /= max(np.linalg.norm(away), 1e-9)
    R_w = (grasp.wrap_orientation(h, placement.flip) if placement.wrap
           else grasp.wrist_orientation(h, open_dir, away, flip=placement.flip))
    palm = grasp.palm_target(h, R_w, placement)
    q_open, q_pre, q_grasp = grasp.open_pose(), grasp.preshape_pose(), grasp.grasp_pose(h.thickness)
    if seated is not None:
        R_w = hand_lib.matrix_from_wrist_euler(seated[3:6])
        palm = seated[:3] + R_w @ np.asarray(hand_lib.PALM_OFFSET)
        q_grasp = grasp.gripping(seated[6:], params.grip_closure)
    x_w = grasp.wrist_position(palm, R_w)
    x_pre = x_w + params.delta * h.normal
    extent = drag_extent(scene, params)
    plan = Plan()
    rpy = continuous_euler(R_w, None)

    def q(x, R, fingers, prev_rpy):
        e = continuous_euler(R, prev_rpy)
        return np.concatenate([x, e, fingers]), e

    for k in range(params.approach_frames):
        a = (k + 1) / params.approach_frames
        target, rpy = q((1 - a) * x_pre + a * x_w, R_w, (1 - a) * q_open + a * q_pre, rpy)
        plan.add("approach", k, target)
    for k in range(params.grasp_frames):
        a = min(1.0, 1.5 * (k + 1) / params.grasp_frames)  # close, then hold
        target, rpy = q(x_w, R_w, (1 - a) * q_pre + a * q_grasp, rpy)
        plan.add("grasp", k, target)
    R_t, palm_t = R_w, palm
    for k in range(params.drag_frames):
        a = (k + 1) / params.drag_frames
        if t.joint.is_revolute:
            R_d = axis_angle_matrix(axis, a * extent)
            palm_t = pivot + R_d @ (palm - pivot)
            R_t = R_d @ R_w
        else:
            palm_t = palm + a * extent * open_dir
        target, rpy = q(grasp.wrist_position(palm_t, R_t), R_t, q_grasp, rpy)
        plan.add("drag", k, target)
    n_final = R_t @ (R_w.T @ h.normal)
    x_final = grasp.wrist_position(palm_t, R_t)
    for k in range(params.release_frames):
        a = (k + 1) / params.release_frames
        fingers = q_grasp + min(1.0, 2 * a) * (q_open - q_grasp)
        target, rpy = q(x_final + a * params.retract * n_final, R_t, fingers, rpy)
        plan.add("release", k, target)
    return plan


def _object_joint_positions(scene: Scene, d: mujoco.MjData) -> tuple[float, ...]:
    """Every movable object joint in URDF order: the simulated target, the locked ones at their lower limit."""
    s = scene.config.scale
    out = []
    for j in scene.obj.movable_joints:
        if j.name == scene.obj.target.joint.name:
            out.append(float(d.qpos[scene.ids.target_qpos]))
        else:
            out.append(float(j.lower if j.is_revolute else s * j.lower))
    return tuple(out)


def execute(scene: Scene, plan: Plan, params: GeneratorParams, damping_scale: float = 1.0):
    """Run the plan in the C engine; returns (frames, stats)."""
    m, ids = scene.model, scene.ids
    m = mujoco.MjModel.from_xml_string(scene.xml) if damping_scale != 1.0 else m
    m.dof_damping[ids.target_dof] = scene.config.damping * damping_scale
    d = mujoco.MjData(m)
    lo, hi = ids.hand_range[:, 0], ids.hand_range[:, 1]
    q0 = np.clip(plan.targets[0], lo, hi)
    q0[:6] = plan.targets[0][:6] - (plan.targets[1][:6] - plan.targets[0][:6])  # start one step back
    d.qpos[ids.target_qpos] = ids.target_range[0]
    d.qpos[ids.hand_qpos] = np.clip(q0, lo, hi)
    d.ctrl[ids.hand_actuators] = d.qpos[ids.hand_qpos]
    mujoco.mj_forward(m, d)
    for _ in range(params.settle_frames * params.substeps):
        mujoco.mj_step(m, d)
    is_hand = scene.geom_mask(ids.hand_geoms)
    frames, pen, limit_excess, palm_dist = [], 0.0, 0.0, []
    wrist = ids.wrist_body
    for phase, step, target in zip(plan.phases, plan.steps, plan.targets, strict=True):
        d.ctrl[ids.hand_actuators] = np.clip(target, lo, hi)
        for _ in range(params.substeps):
            mujoco.mj_step(m, d)
            pen = max(pen, contact_depth(is_hand, d))
        if not np.all(np.isfinite(d.qpos)):
            raise DragMeshError(f"{scene.obj.folder}: physics went non-finite while executing the plan")
        hq = d.qpos[ids.hand_qpos].copy()
        limit_excess = max(limit_excess, float(np.max(np.maximum(lo - hq, hq - hi))))
        palm_dist.append(float(np.linalg.norm(d.site_xpos[ids.palm_site] - d.site_xpos[ids.handle_site])))
        w = d.xquat[wrist]
        frames.append(Frame(
            phase=phase, step=step, virtual_xyz=tuple(hq[:3]), wrist_rpy=tuple(hq[3:6]), finger_dofs=tuple(hq[6:]),
            wrist_pos=tuple(float(x) for x in d.xpos[wrist]), wrist_rot=(float(w[1]), float(w[2]), float(w[3]),
                                                                        float(w[0])),
            joint_positions=_object_joint_positions(scene, d), hand_target=tuple(float(x) for x in target)))
    return frames, {"max_penetration_m": pen, "hand_limit_excess": max(limit_excess, 0.0), "palm_dist": palm_dist}


def handle_grip(scene: Scene, d: mujoco.MjData, margin: float) -> tuple[int, float]:
    """(hand geoms in contact with the handle, their summed normal force in N) in state ``d``: contacts between a
    hand geom and the object whose point lies in the handle's box grown by ``margin`` (a handle need not be a mesh
    of its own)."""
    m, h = scene.model, scene.handle
    R = np.stack([h.long_axis, h.normal, h.short_axis], axis=1)
    half = np.array([h.length, h.thickness, h.width]) / 2 + margin
    hand = set(scene.ids.hand_geoms.tolist())
    touching, force, f6 = set(), 0.0, np.zeros(6)
    for i, c in enumerate(d.contact[: d.ncon]):
        if (c.geom1 in hand) == (c.geom2 in hand) or np.any(np.abs(R.T @ (c.pos - h.centre)) > half):
            continue
        mujoco.mj_contactForce(m, d, i, f6)
        touching.add(c.geom1 if c.geom1 in hand else c.geom2)
        force += float(f6[0])
    return len(touching), force


def start_grip(scene: Scene, frames: list[Frame], params: GeneratorParams) -> tuple[int, float]:
    """:func:`handle_grip` in the state the task resets to: the drag-start frame (a seated grasp's fingers at their
    grip: ``Trajectory.start_hand_q``), settled as a reset settles it."""
    traj = _drag(scene, frames, params)
    frame = frames[traj.drag_start]
    d = scene.settled_state(traj.start_hand_q, frame.joint_positions[traj.target_index], RESET_SETTLE_SUBSTEPS)
    return handle_grip(scene, d, params.grip_margin)


def quality(scene: Scene, frames: list[Frame], stats: dict, params: GeneratorParams, extent: float) -> dict:
    traj = Trajectory(tuple(frames), header={"target": {"joint_index": _target_index(scene)}})
    drag = [i for i, f in enumerate(frames) if f.phase == "drag"]
    q_start = traj.target_q[drag[0]]
    achieved = float(traj.target_q[drag[0]: drag[-1] + 1].max() - q_start)
    opened = achieved >= params.min_open_fraction * extent
    q_done = traj.q_done
    # q_done comes from all frames (design §4); contact must pass it during the drag itself, so a part that
    # only falls open after the release (gravity) does not count
    reached = bool(traj.target_q[drag[0]: drag[-1] + 1].max() >= q_done) and opened
    within = stats["hand_limit_excess"] <= params.limit_tolerance
    shallow = stats["max_penetration_m"] <= params.max_penetration
    until = next((i for i in drag if traj.target_q[i] >= q_done), drag[-1])
    dist = np.asarray(stats["palm_dist"][drag[0]: until + 1])
    near = np.flatnonzero(dist <= params.max_palm_distance)  # the task arms its detachment check from here
    palm = float(dist[near[0]:].max()) if len(near) else float(dist.min())
    held = len(near) > 0 and palm <= params.max_palm_distance
    reasons = []
    if not opened:
        reasons.append(f"contact opened the joint by {achieved:.4f} of the planned {extent:.4f}")
    elif not reached:
        reasons.append(f"the drag reached q = {q_start + achieved:.4f} < q_done = {q_done:.4f} (the part moved on "
                       f"after the release)")
    if not within:
        reasons.append(f"hand left its joint limits by {stats['hand_limit_excess']:.4f}")
    if not shallow:
        reasons.append(f"hand-object penetration {stats['max_penetration_m']:.4f} m")
    if not held:
        reasons.append(f"the palm left the handle ({palm:.3f} m > {params.max_palm_distance} m) before q_done: "
                       "tracking would count it as detached")
    contacts, force = start_grip(scene, frames, params)
    return {"passed": bool(reached and within and shallow and held), "opened_past_q_done": bool(reached),
            "max_palm_distance_m": round(palm, 4), "grip": force >= params.min_grip_force,
            "handle_contacts": contacts, "handle_force_n": round(force, 2),
            "achieved_opening": round(achieved, 6), "planned_opening": round(float(extent), 6),
            "q_done": q_done, "max_penetration_m": round(stats["max_penetration_m"], 6),
            "hand_within_limits": bool(within), "reasons": reasons}


def _drag(scene: Scene, frames: list[Frame], params: GeneratorParams) -> Trajectory:
    """An executed placement's frames as the trajectory a task replays (its target, frame time and grip)."""
    return Trajectory(tuple(frames), header={"target": {"joint_index": _target_index(scene)},
                                             "scene": {"frame_dt": scene.config.timestep * params.substeps},
                                             **_grip_header(frames, params)})


def _grip_header(frames: list[Frame], params: GeneratorParams) -> dict:
    """A seated grasp's finger targets at the drag start: its fingers there closed ``grip_closure`` further (the
    header's ``grip``: a task starts its fingers there, so that a hand whose targets stay put grips); nothing for the
    planned grasp, whose fingers start where they stopped."""
    if params.seat_depth is None:
        return {}
    start = frames[Trajectory(tuple(frames), header={}).drag_start]
    return {"grip": [float(x) for x in grasp.gripping(np.asarray(start.finger_dofs), params.grip_closure)]}


def _target_index(scene: Scene) -> int:
    names = [j.name for j in scene.obj.movable_joints]
    return names.index(scene.obj.target.joint.name)


def cached_path(obj: GAPartNetObject, scene: Scene, params: GeneratorParams) -> Path:
    """Where ``generate`` keeps its trajectory for this object, scene and parameters: keyed by the object folder's
    files, the scene's model, the parameters, the generator's version and MuJoCo's."""
    key = hash_files([], extra="\0".join([object_hash(obj.folder), GENERATOR_VERSION, mujoco.__version__, repr(params),
                                           repr(scene.config), scene.xml]))
    return cache_dir() / "trajectories" / f"{key}.json"


def generate(obj: GAPartNetObject, params: GeneratorParams = GeneratorParams(), scene_config: SceneConfig | None = None,
             scene: Scene | None = None) -> Trajectory:
    """Plan and execute a trajectory for ``obj``; returns it with a header holding the quality gate. Deterministic:
    the palm placements are tried in a fixed order, so there is no seed, and the result is cached on disk
    (``cached_path``; floats round-trip exactly, so a cached trajectory is the generated one)."""
    scene = scene or build_scene(obj, scene_config or SceneConfig())
    cache = cached_path(obj, scene, params)
    if cache.is_file():
        try:
            return read_trajectory(cache)
        except DragMeshError:
            cache.unlink(missing_ok=True)
    traj = _generate(obj, params, scene)
    with contextlib.suppress(DragMeshError):  # an unwritable cache only costs the next call the generation
        write_trajectory(traj, cache)
    return traj


def holds(scene: Scene, traj: Trajectory, substeps: int, hold_steps: int) -> float:
    """The highest of 1 and ``HOLD_DAMPINGS`` (in order, up to the first not reached) at which the expert drag of
    ``traj`` (its frames ``substeps`` physics steps apart) takes the part past q_done within an episode: its hand
    targets replayed as the task's expert prior holds them (within the hand's ranges, the last held to
    ``hold_steps`` control steps) from the state the task resets to, at that multiple of the nominal damping."""
    dt = scene.config.timestep * substeps
    targets = np.clip(traj.held_targets(dt, hold_steps), scene.ids.hand_range[:, 0], scene.ids.hand_range[:, 1])
    held = 1.0
    for damping in HOLD_DAMPINGS:
        if contacts.replay(scene, (traj.start_hand_q, traj.q_start), targets, substeps, RESET_SETTLE_SUBSTEPS,
                           traj.q_done, damping).steps is None:
            break
        held = damping
    return held


def _generate(obj: GAPartNetObject, params: GeneratorParams, scene: Scene) -> Trajectory:
    t0 = time.time()
    extent = drag_extent(scene, params)
    if extent <= 0:
        raise DragMeshError(f"{obj.folder}: target joint has no range to drag through")
    attempts, best, planned = [], None, []
    unseated = replace(params, seat_depth=None)

    def consider(k: int, placement: grasp.GraspParams, frames: list[Frame], stats: dict,
                 kind: GeneratorParams, floor: float = 0.0) -> bool:
        """Rank one executed placement (``kind``: the params it was executed under, seated or not; kept only where it
        holds past ``floor``); whether the search stops at it."""
        nonlocal best
        q = quality(scene, frames, stats, kind, extent)
        held = holds(scene, _drag(scene, frames, kind), params.substeps, params.hold_steps) \
            if q["passed"] and params.placement_choice == "holds" else 1.0
        attempts.append({"placement": k, "seated": kind.seat_depth is not None, **{
            x: q[x] for x in ("passed", "grip", "handle_contacts", "handle_force_n", "achieved_opening",
                              "max_penetration_m", "max_palm_distance_m")}, "holds": held})
        # passing, holding the most (ranked by it), gripping (the first of each), then the farthest opening
        rank = (q["passed"], held, q["grip"], 0.0 if q["passed"] else q["achieved_opening"])
        if best is None or (rank > best[0] and held > floor):
            best = (rank, frames, q, k, placement, kind)
        return q["passed"] and q["grip"] and params.placement_choice == "first"

    for k, placement in enumerate(params.placements):
        frames, stats = execute(scene, make_plan(scene, params, placement), params)
        if params.seat_depth is not None:
            planned.append((k, placement, frames, stats))
            start = frames[Trajectory(tuple(frames), header={}).drag_start]
            seated = grasp.seat(scene, np.asarray(start.hand_q), start.joint_positions[_target_index(scene)],
                                params.seat_depth)
            frames, stats = execute(scene, make_plan(scene, params, placement, seated), params)
        if consider(k, placement, frames, stats, params):
            break
    if not best[2]["passed"] or params.placement_choice == "holds":  # the planned ones, executed on the way
        floor = best[0][1] if best[2]["passed"] else 0.0  # a planned grasp must hold more than every seated one
        for k, placement, frames, stats in planned:
            if consider(k, placement, frames, stats, unseated, floor):
                break
    _, frames, q, k, placement, kept = best
    if q["passed"] and not q["grip"]:
        q["note"] = (f"no passing placement grips the handle at the drag start: the hand presses on it with "
                     f"{q['handle_force_n']} N in the one kept, {params.min_grip_force} N wanted")
    h = scene.handle
    t = obj.target
    header = {
        "object_id": obj.object_id, "category": obj.category, "object_folder": str(obj.folder),
        "target": {"joint_name": t.joint.name, "joint_index": _target_index(scene), "link": t.part.link,
                   "part_category": t.part.category, "type": "revolute" if t.joint.is_revolute else "prismatic",
                   "range": list(scene.ids.target_range)},
        "joints": [j.name for j in obj.movable_joints],
        "handle": {"centre": h.centre.tolist(), "long_axis": h.long_axis.tolist(), "normal": h.normal.tolist(),
                   "short_axis": h.short_axis.tolist(), "thickness": h.thickness, "source": h.source},
        "scene": {"scale": scene.config.scale, "object_pos": list(scene.config.object_pos),
                  "timestep": scene.config.timestep, "substeps_per_frame": params.substeps,
                  "frame_dt": scene.config.timestep * params.substeps, "damping": scene.config.damping},
        "generator": {"version": GENERATOR_VERSION, "params": _jsonable(asdict(params)), "placement": k,
                      "placement_params": asdict(placement), "seated": kept.seat_depth is not None,
                      "attempts": attempts},
        "quality": q, "wall_s": round(time.time() - t0, 3), **_grip_header(frames, kept),
        "hand": {"side": scene.config.hand.side, "dof_names": list(hand_lib.dof_names(scene.config.hand.side))},
    }
    return Trajectory(frames=tuple(frames), header=header)


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return x
