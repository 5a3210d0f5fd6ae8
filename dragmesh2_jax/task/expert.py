"""The expert drag as the task reads it, beyond the paper: the prior a residual policy adds to
(``TaskConfig.expert_prior``) and the units of the relative measures: ``relative_load``'s, the expert's own peak wrist
load on the object at the world's damping, so that one constraint bounds every object's pull by what its expert needs
there, and ``relative_palm_speed``'s, its settled palm peak at x1, so that one bounds every object's pace by its own."""

from __future__ import annotations

import contextlib
import hashlib
from pathlib import Path

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from dragmesh2_jax.assets.hand import NUM_DOFS, NUM_VIRTUAL
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.io import atomic_write_bytes, cache_dir, object_hash
from dragmesh2_jax.physics import contacts
from dragmesh2_jax.physics.base import Start
from dragmesh2_jax.scene import Scene
from dragmesh2_jax.task.config import TaskConfig
from dragmesh2_jax.task.protocol import START_STEPS
from dragmesh2_jax.task.starts import reset_starts
from dragmesh2_jax.trajectory.schema import Trajectory

#: The measure whose unit is the expert's peak wrist load (``config.MEASURES``).
RELATIVE_LOAD = "relative_load"
#: The measure whose unit is the expert's settled palm peak speed at x1 (``config.MEASURES``).
RELATIVE_PACE = "relative_palm_speed"
#: The damping multipliers the expert's load is probed at (the recipe's training range, an octave apart); between
#: them it is interpolated in log-damping, beyond them held at the nearest.
LOAD_DAMPINGS = (1.0, 2.0, 4.0, 8.0)


def held_targets(traj: Trajectory, config: TaskConfig, pace: float = 1.0) -> np.ndarray:
    """The expert drag's hand target at ``pace`` for each control step of an episode, the last one held."""
    return traj.held_targets(config.control_dt, config.episode_length, pace)


def reachable_targets(scene: Scene, traj: Trajectory, config: TaskConfig, pace: float = 1.0) -> np.ndarray:
    """:func:`held_targets` within the hand's joint ranges (what its PD targets can be)."""
    return np.clip(held_targets(traj, config, pace), scene.ids.hand_range[:, 0], scene.ids.hand_range[:, 1])


def expert_replay(scene: Scene, traj: Trajectory, config: TaskConfig, substeps: int, damping: float = 1.0,
                  pace: float = 1.0) -> contacts.Replay:
    """The expert drag at ``pace`` replayed on the C engine from the task's exact start at ``damping`` x nominal, up
    to success (``contacts.replay``: its peak wrist load, deepest penetration and steps)."""
    return contacts.replay(scene, reset_starts(scene, traj, None)[0], reachable_targets(scene, traj, config, pace),
                           substeps, config.settle_substeps, traj.q_done_at(config.rho), damping)


def expert_drag(scene: Scene, traj: Trajectory, config: TaskConfig) -> np.ndarray:
    """The expert drag's hand target per control step of an episode under ``expert_prior``; else nothing (an empty
    array)."""
    if not config.expert_prior:
        return np.zeros(0, np.float32)
    if scene.config.effector != "hand":
        raise DragMeshError("expert_prior needs the hand (the expert drag moves the hand, not a gripper)")
    return held_targets(traj, config)


def _reaching(planned: jnp.ndarray, q: jnp.ndarray) -> jnp.ndarray:
    """The first step whose ``planned`` joint (monotone) reaches ``q``, the plan's last for a part past its end."""
    return jnp.minimum(jnp.searchsorted(planned, q, side="left"), planned.shape[0] - 1)


def planned_step(params, q: jnp.ndarray) -> jnp.ndarray:
    """The first step of the expert drag whose planned joint (``params.schedule``, made monotone) reaches the part's
    joint ``q``, the plan's last for a part past its end."""
    return _reaching(jax.lax.cummax(params.schedule), q)  # sorted, as searchsorted needs


def drag_step(config: TaskConfig, step: jnp.ndarray, q: jnp.ndarray, params, begun: jnp.ndarray | None = None
              ) -> jnp.ndarray:
    """The step of the expert drag whose target the prior applies at episode step ``step``: that step, under
    ``config.prior_floor`` at least :func:`planned_step` of the part's joint ``q`` now, under
    ``config.prior_from_start`` that step after ``begun`` (the planned step of the part's joint where the episode
    began, kept by the task's reset), and under ``config.prior_lead`` at most the first whose planned joint lies
    prior_lead x the part's range past ``q``."""
    if not (config.prior_floor or config.prior_from_start) and config.prior_lead is None:
        return step  # time-indexed: nothing of the plan is read
    planned = jax.lax.cummax(params.schedule)  # once per step, for the floor and the lead alike
    if config.prior_floor:
        step = jnp.maximum(step, _reaching(planned, q))
    if config.prior_from_start:
        step = jnp.minimum(step + begun, planned.shape[0] - 1)
    if config.prior_lead is None:
        return step
    lead = config.prior_lead * (params.q_goal - params.q_start)
    return jnp.minimum(step, jnp.searchsorted(planned, q + lead, side="right"))


#: The leading action channels each ``residual_scope`` narrows: the wrist's translation, its six virtual DoFs, the hand.
SCOPE_CHANNELS = {"translation": 3, "wrist": NUM_VIRTUAL, "hand": NUM_DOFS}


def residual_gain(config: TaskConfig) -> np.ndarray:
    """The factor on each of the hand's action channels before the policy's residual adds to the expert's:
    ``config.residual_scale`` on the channels of ``config.residual_scope``, 1 on the rest."""
    gain = np.ones(NUM_DOFS, np.float32)
    gain[:SCOPE_CHANNELS[config.residual_scope]] = config.residual_scale
    return gain


def residual_step(config: TaskConfig, params, info: dict, hand_q: jnp.ndarray, obj_q: jnp.ndarray,
                  a: jnp.ndarray) -> tuple[jnp.ndarray, jnp.ndarray, jnp.ndarray]:
    """(the hand's PD target, the applied action, the action PICA's terms charge) of a residual ``a`` in [-1, 1] over
    the expert drag at the episode's step (``info``: the task state's; under ``config.residual_ramp`` the residual
    eased in from the episode's start) (``config.residual_on``: added to the drag's increment within the bound, the sum
    charged; or offsetting its target, the residual charged: its own output, as the policy chose it)."""
    step = drag_step(config, info["step"], obj_q, params, info.get("drag_begun"))
    drag, gain = params.drag[step], residual_gain(config)
    if config.residual_ramp:
        gain = gain * jnp.minimum(1.0, (info["step"] + 1.0) / config.residual_ramp)
    if config.residual_on == "target":
        ctrl = jnp.clip(drag + config.alpha * gain * a, params.hand_lo, params.hand_hi)
        return ctrl, jnp.clip((ctrl - hand_q) / config.alpha, -1.0, 1.0), a
    applied = jnp.clip(gain * a + jnp.clip((drag - hand_q) / config.alpha, -1.0, 1.0), -1.0, 1.0)
    return jnp.clip(hand_q + config.alpha * applied, params.hand_lo, params.hand_hi), applied, applied


def expert_load(scene: Scene, traj: Trajectory, config: TaskConfig, nominal: Start, bank: list[Start],
                substeps: int, per_start: bool = True) -> np.ndarray:
    """The expert drag's peak wrist load (N) at each of ``LOAD_DAMPINGS`` (columns), one row per start of the task's
    reset ``bank``: every row from the task's unperturbed start ``nominal`` (``config.expert_load_unit`` "grasp", or
    not ``per_start``) or each from its own start ("start"), each up to success; probed only when a constraint reads
    ``relative_load`` (else NaN, never read)."""
    return _probed(scene, traj, config, nominal, bank, substeps, per_start, RELATIVE_LOAD, LOAD_DAMPINGS,
                   lambda r: r.peak_load)


def expert_pace(scene: Scene, traj: Trajectory, config: TaskConfig, nominal: Start, bank: list[Start],
                substeps: int, per_start: bool = True) -> np.ndarray:
    """The expert drag's settled palm peak speed (m/s; after the episode's first ``START_STEPS``, as the evaluation's
    figure) at x1, one row per start of the reset ``bank`` as :func:`expert_load`'s; probed only when a constraint
    reads ``relative_palm_speed`` (else NaN)."""
    return _probed(scene, traj, config, nominal, bank, substeps, per_start, RELATIVE_PACE, (1.0,),
                   lambda r: r.palm_peak)[:, 0]


def _probed(scene: Scene, traj: Trajectory, config: TaskConfig, nominal: Start, bank: list[Start], substeps: int,
            per_start: bool, measure: str, dampings: tuple[float, ...], read) -> np.ndarray:
    """``read`` of the expert drag's replay (``contacts.replay``) at each of ``dampings`` (columns), one row per start
    of ``bank`` (:func:`expert_load`), cached; NaN where no constraint reads ``measure``."""
    shape = (len(bank), len(dampings))
    if not any(c.measure == measure for c in config.reward.constraints):
        return np.full(shape, np.nan, np.float32)
    if scene.config.effector != "hand":
        raise DragMeshError(f"{measure} needs the hand (the expert drag moves the hand, not a gripper)")
    targets, until = reachable_targets(scene, traj, config), traj.q_done_at(config.rho)
    rows = bank if per_start and config.expert_load_unit == "start" else [nominal]
    cache = _cache(scene, targets, rows, substeps, config.settle_substeps, until, measure, dampings)
    values = _read_cached(cache, len(rows), len(dampings))
    if values is None:
        values = np.asarray([[read(contacts.replay(scene, s, targets, substeps, config.settle_substeps, until,
                                                   damping, START_STEPS)) for damping in dampings] for s in rows],
                            np.float32)
        with contextlib.suppress(OSError, DragMeshError):  # an unwritable cache only costs the next task the probe
            atomic_write_bytes(cache, values.tobytes())
    return np.broadcast_to(values, shape).copy()


def _cache(scene: Scene, targets: np.ndarray, rows: list[Start], substeps: int, settle_substeps: int,
           until: float, measure: str, dampings: tuple[float, ...]) -> Path:
    """Where the expert's probed figures are kept (every task of the recipe probes them; the C engine's replays are
    deterministic): keyed by the object folder's files, the scene and its model, the targets, the starts, the stepping
    and MuJoCo's version; the loads in ``expert_load``, each other measure's in its own folder."""
    stepping = (substeps, settle_substeps, float(until), dampings)
    # the loads keyed as before the pace was probed, so the loads already cached stay valid
    key = repr(stepping) if measure == RELATIVE_LOAD else repr((*stepping, START_STEPS))
    h = hashlib.sha256("\0".join([object_hash(scene.obj.folder), repr(scene.config), scene.xml, mujoco.__version__,
                                   key]).encode())
    h.update(np.ascontiguousarray(targets, np.float64).tobytes())
    for hand_q, q in rows:
        h.update(np.ascontiguousarray(hand_q, np.float64).tobytes() + np.float64(q).tobytes())
    folder = "expert_load" if measure == RELATIVE_LOAD else f"expert_{measure}"
    return cache_dir() / folder / f"{h.hexdigest()[:16]}.f32"


def _read_cached(path: Path, rows: int, cols: int) -> np.ndarray | None:
    """The cached figures (``rows`` x ``cols``), or None where there are none whole."""
    with contextlib.suppress(OSError):
        data = path.read_bytes()
        if len(data) == rows * cols * np.dtype(np.float32).itemsize:
            return np.frombuffer(data, np.float32).reshape(rows, cols)
    return None


def load_unit(expert_load: jnp.ndarray, damping: jnp.ndarray) -> jnp.ndarray:
    """The expert's peak wrist load at a world's damping multiplier (``expert_load``: its start's row, at
    ``LOAD_DAMPINGS``)."""
    return jnp.interp(jnp.log2(damping), jnp.log2(jnp.asarray(LOAD_DAMPINGS)), expert_load)
