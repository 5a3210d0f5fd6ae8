"""The task's start states: the expert grasp, or a seeded bank of perturbations of it (``config.ResetNoise``; not in
the paper, whose reset is exact: design §4)."""

from __future__ import annotations

import numpy as np

from dragmesh2_jax.assets.hand import NUM_VIRTUAL
from dragmesh2_jax.physics.base import Start
from dragmesh2_jax.scene import Scene
from dragmesh2_jax.task.config import ResetNoise
from dragmesh2_jax.trajectory.schema import RHO, Trajectory


def reset_starts(scene: Scene, traj: Trajectory, noise: ResetNoise | None, start: Start | None = None,
                 rho: float = RHO) -> list[Start]:
    """The start states of the task: ``start`` (default: the expert grasp, ``Trajectory.start_hand_q``), or
    ``noise.bank`` seeded perturbations of it (truncated normal on the wrist pose and, for the hand, the active
    finger joints; the object joint opened by a uniform fraction of the distance to q_done at ``rho``)."""
    if start is None:
        start = traj.start_hand_q, traj.frames[traj.drag_start].joint_positions[traj.target_index]
    hand_q, obj_q = np.asarray(start[0], np.float64), float(start[1])
    if noise is None:
        return [(hand_q, obj_q)]
    rng = np.random.default_rng(noise.seed)
    hand = scene.config.effector == "hand"
    fingers = np.flatnonzero(scene.config.active_dofs()[NUM_VIRTUAL:]) + NUM_VIRTUAL if hand else []
    trunc = lambda std, n: std * np.clip(rng.standard_normal(n), -2.0, 2.0)  # noqa: E731
    starts = []
    for _ in range(noise.bank):
        dq = np.zeros(len(hand_q))
        dq[:3], dq[3:NUM_VIRTUAL] = trunc(noise.wrist_pos, 3), trunc(noise.wrist_rot, 3)
        dq[fingers] = trunc(noise.fingers, len(fingers))
        opened = rng.uniform(0.0, noise.object_q) * (traj.q_done_at(rho) - traj.q_start)
        starts.append((hand_q + dq, obj_q + opened))
    return starts
