"""The expert drag as the task reads it, beyond the paper: the prior a residual policy adds to
(``TaskConfig.expert_prior``) and the unit of the ``relative_load`` measure, the expert's own peak wrist load on the
object at the world's damping, so that one constraint bounds every object's pull by what its expert needs there."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.assets.hand import NUM_DOFS
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.physics import contacts
from dragmesh2_jax.physics.base import Start
from dragmesh2_jax.scene import Scene
from dragmesh2_jax.task.config import TaskConfig
from dragmesh2_jax.task.starts import reset_starts
from dragmesh2_jax.trajectory.schema import Trajectory

#: The measure whose unit is the expert's peak wrist load (``config.MEASURES``).
RELATIVE_LOAD = "relative_load"
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


def residual_gain(config: TaskConfig) -> np.ndarray:
    """The factor on each of the hand's action channels before the policy's residual adds to the expert's:
    ``config.residual_scale`` on the channels of ``config.residual_scope``, 1 on the rest."""
    gain = np.ones(NUM_DOFS, np.float32)
    gain[:3 if config.residual_scope == "translation" else NUM_DOFS] = config.residual_scale
    return gain


def expert_load(scene: Scene, traj: Trajectory, config: TaskConfig, nominal: Start, bank: list[Start],
                substeps: int) -> np.ndarray:
    """The expert drag's peak wrist load (N) at each of ``LOAD_DAMPINGS`` (columns), one row per start of the task's
    reset ``bank``: every row from the task's unperturbed start ``nominal`` (``config.expert_load_unit`` "grasp") or
    each from its own start ("start"), each up to success; probed only when a constraint reads ``relative_load``
    (else NaN, never read)."""
    shape = (len(bank), len(LOAD_DAMPINGS))
    if not any(c.measure == RELATIVE_LOAD for c in config.reward.constraints):
        return np.full(shape, np.nan, np.float32)
    if scene.config.effector != "hand":
        raise DragMeshError(f"{RELATIVE_LOAD} needs the hand (the expert drag moves the hand, not a gripper)")
    targets = reachable_targets(scene, traj, config)
    peaks = [[contacts.peak_load(scene, s, targets, substeps, config.settle_substeps, traj.q_done_at(config.rho),
                                 damping) for damping in LOAD_DAMPINGS]
             for s in (bank if config.expert_load_unit == "start" else [nominal])]
    return np.broadcast_to(np.asarray(peaks, np.float32), shape).copy()


def load_unit(expert_load: jnp.ndarray, damping: jnp.ndarray) -> jnp.ndarray:
    """The expert's peak wrist load at a world's damping multiplier (``expert_load``: its start's row, at
    ``LOAD_DAMPINGS``)."""
    return jnp.interp(jnp.log2(damping), jnp.log2(jnp.asarray(LOAD_DAMPINGS)), expert_load)
