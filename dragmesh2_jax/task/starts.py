"""The task's start states: the expert grasp, or a seeded bank of perturbations of it (``config.ResetNoise``; not in
the paper, whose reset is exact: design §4).

A perturbation drawn as is (``ResetNoise.clear`` off) can put the hand millimetres into the handle: a part that
starts open moves its handle into the still hand, and any wrist shift presses a bar the fingers wrap into the palm
or a finger. The first control steps then push the hand out with a large contact force, which the penetration and
palm figures count as the policy's. A clear start instead moves the wrist with the part, as the expert drag does,
and lets a perturbed hand that reaches into the part relax out of it: physics steps with its drives following it (no
drive force, the part held), the contacts pushing it out, until it lies no more than ``CLEARANCE_MARGIN`` deeper than
the unperturbed grasp at that opening, or ``RELAX_SUBSTEPS`` have passed; one still deeper has its perturbation
halved and relaxed again. A seated start (``ResetNoise.seat``) first eases the unperturbed grasp itself out the
same way, to within ``SEATED_DEPTH``: a grasp planned on other contacts than the run's can lie millimetres inside
the handle, and the perturbations are then kept clear around a hand resting on it."""

from __future__ import annotations

import mujoco
import numpy as np

from dragmesh2_jax.assets.hand import NUM_VIRTUAL
from dragmesh2_jax.physics.base import Start
from dragmesh2_jax.scene import Scene, contact_depth
from dragmesh2_jax.task.config import ResetNoise
from dragmesh2_jax.trajectory.schema import RHO, Trajectory

#: m: how much deeper than the unperturbed grasp a clear start's hand may lie in the part (the soft contacts' own
#: give, so that a perturbation which only touches the handle stands as drawn).
CLEARANCE_MARGIN = 0.0005
#: m: how deep a seated grasp may rest in the part (the hand's contacts give about 1 mm under its drives).
SEATED_DEPTH = 0.001
#: The most physics steps a perturbed hand relaxes out of the part (0.4 s; on 11712 the median start of a relaxation
#: this long lies 0.2 mm deep, of one half as long 0.8 mm).
RELAX_SUBSTEPS = 96
#: The fractions of a perturbation tried, in order, until its relaxed start is clear (none clear: the unperturbed).
SCALES = 0.5 ** np.arange(4)


def reset_starts(scene: Scene, traj: Trajectory, noise: ResetNoise | None, start: Start | None = None,
                 rho: float = RHO) -> list[Start]:
    """The start states of the task: ``start`` (default: the expert grasp, ``Trajectory.start_hand_q``), or
    ``noise.bank`` seeded perturbations of it (truncated normal on the wrist pose and, for the hand, the active
    finger joints; the object joint opened by a uniform fraction of the distance to q_done at ``rho``), each kept out
    of the part where ``noise.clear`` (module docstring)."""
    if start is None:
        start = traj.start_hand_q, traj.frames[traj.drag_start].joint_positions[traj.target_index]
    hand_q, obj_q = np.asarray(start[0], np.float64), float(start[1])
    if noise is None:
        return [(hand_q, obj_q)]
    rng = np.random.default_rng(noise.seed)
    hand = scene.config.effector == "hand"
    fingers = np.flatnonzero(scene.config.active_dofs()[NUM_VIRTUAL:]) + NUM_VIRTUAL if hand else []
    trunc = lambda std, n: std * np.clip(rng.standard_normal(n), -2.0, 2.0)  # noqa: E731
    clear = _Clearance(scene, traj, hand_q, obj_q, noise.seat) if noise.clear else None
    starts = []
    for _ in range(noise.bank):
        dq = np.zeros(len(hand_q))
        dq[:3], dq[3:NUM_VIRTUAL] = trunc(noise.wrist_pos, 3), trunc(noise.wrist_rot, 3)
        dq[fingers] = trunc(noise.fingers, len(fingers))
        opened = rng.uniform(0.0, noise.object_q) * (traj.q_done_at(rho) - traj.q_start)
        starts.append(clear(dq, obj_q + opened) if clear else (hand_q + dq, obj_q + opened))
    return starts


class _Clearance:
    """Clear starts around the unperturbed one (``hand_q`` at ``obj_q``) on the C engine."""

    def __init__(self, scene: Scene, traj: Trajectory, hand_q: np.ndarray, obj_q: float, seat: bool):
        self.scene, self.hand_q, self.seat = scene, hand_q, seat
        self.data = mujoco.MjData(scene.model)
        self.is_hand = scene.geom_mask(scene.ids.hand_geoms)
        end = next((b for p, a, b in traj.phase_blocks() if p == "drag" and a == traj.drag_start), traj.drag_start + 1)
        wrist = traj.hand_q[traj.drag_start:end, :NUM_VIRTUAL]
        self.path_q = np.maximum.accumulate(traj.target_q[traj.drag_start:end])  # np.interp wants it non-decreasing
        self.path_wrist = wrist - wrist[0]

    def __call__(self, dq: np.ndarray, obj_q: float) -> Start:
        base = self.followed(obj_q)
        if self.seat:
            base = self._relaxed(base, obj_q, SEATED_DEPTH)
        allowed = self._depth(base, obj_q) + CLEARANCE_MARGIN
        for s in SCALES:
            hand_q = self._relaxed(base + s * dq, obj_q, allowed)
            if self._depth(hand_q, obj_q) <= allowed:
                return hand_q, obj_q
        return base, obj_q

    def followed(self, obj_q: float) -> np.ndarray:
        """The unperturbed start with its wrist where the expert drag holds it at ``obj_q``."""
        q = self.hand_q.copy()
        q[:NUM_VIRTUAL] += [np.interp(obj_q, self.path_q, w) for w in self.path_wrist.T]
        return q

    def _write(self, hand_q: np.ndarray, obj_q: float) -> mujoco.MjData:
        ids, d = self.scene.ids, self.data
        mujoco.mj_resetData(self.scene.model, d)
        d.qpos[ids.hand_qpos] = np.clip(hand_q, ids.hand_range[:, 0], ids.hand_range[:, 1])
        d.qpos[ids.target_qpos] = obj_q
        mujoco.mj_forward(self.scene.model, d)
        return d

    def _depth(self, hand_q: np.ndarray, obj_q: float) -> float:
        """The deepest hand-object contact (m) of the pose a reset writes, before it settles."""
        return contact_depth(self.is_hand, self._write(hand_q, obj_q))

    def _relaxed(self, hand_q: np.ndarray, obj_q: float, allowed: float) -> np.ndarray:
        """``hand_q`` relaxed until no contact lies deeper than ``allowed`` (m), at most RELAX_SUBSTEPS."""
        ids, d = self.scene.ids, self._write(hand_q, obj_q)
        for _ in range(RELAX_SUBSTEPS):
            if contact_depth(self.is_hand, d) <= allowed:
                break
            d.ctrl[ids.hand_actuators] = d.qpos[ids.hand_qpos]
            mujoco.mj_step(self.scene.model, d)
            d.qpos[ids.target_qpos], d.qvel[ids.target_dof] = obj_q, 0.0
        return d.qpos[ids.hand_qpos].copy()
