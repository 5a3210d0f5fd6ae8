"""Trajectory-tracking baseline (paper Table 2, row 1; Appendix A.2): each next reference hand pose of the
drag phase becomes the hand PD target; the object state is never replayed, so the part opens only if the
replayed hand motion drags it through contact. It is a controller of the evaluator (``controls="targets"``):
the same cells and metric names as every policy. After the drag block it holds the last pose.

``tracking_delta`` is the reference's ``delta_action`` mode of the same replay (facts §10): the drag sent through the
learned policies' action interface, a = clip((target - q) / alpha, -1, 1), so the PD target never leads the hand by
more than alpha. It tells apart what the increment interface allows from what a policy learns to do with it."""

from __future__ import annotations

import functools
import math

import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.policies.controller import Controller
from dragmesh2_jax.task.env import PullTask
from dragmesh2_jax.task.protocol import Obs

TRACKING = "tracking"
TRACKING_DELTA = "tracking_delta"


def drag_targets(task: PullTask, pace: float = 1.0) -> np.ndarray:
    """Hand targets, one per control step: the frames after the drag start through the end of the first
    contiguous drag block, each held for frame_dt / control_dt steps (1 for ours, 2 for the reference's
    30 Hz files). At another ``pace`` the same path is resampled in time (0.5: twice as many steps, linearly
    interpolated; 1: the frames themselves)."""
    if not (math.isfinite(pace) and pace > 0):
        raise DragMeshError(f"pace must be a positive number, got {pace}")
    traj = task.traj
    frame_dt = traj.header.get("scene", {}).get("frame_dt", 1.0 / 30.0)
    hold = max(1, int(round(frame_dt / task.config.control_dt)))
    start = traj.drag_start
    end = next((b for p, a, b in traj.phase_blocks() if p == "drag" and a == start), len(traj.frames))
    frames = [traj.frames[i].hand_target or traj.frames[i].hand_q for i in range(start + 1, end)]
    targets = np.repeat(np.asarray(frames, np.float32), hold, axis=0)
    n = len(targets)
    t = np.linspace(0.0, n - 1.0, max(1, int(round(n / pace))))
    return np.stack([np.interp(t, np.arange(n), targets[:, j]) for j in range(targets.shape[1])], 1).astype(np.float32)


def replay(targets: jnp.ndarray, obs: Obs, key) -> jnp.ndarray:
    """The PD target of the episode's current step (the last one once the replay is over)."""
    return targets[jnp.minimum(obs.step, targets.shape[0] - 1)]


def tracking_controller(task: PullTask, pace: float = 1.0) -> Controller:
    """The expert drag replayed open-loop (deterministic: det and stoch are the same controller), at ``pace``."""
    return Controller(TRACKING, lambda deterministic: replay, jnp.asarray(drag_targets(task, pace)), controls="targets",
                      key=TRACKING)


def increments(alpha: float, targets: jnp.ndarray, obs: Obs, key) -> jnp.ndarray:
    """The action whose PD target q + alpha a comes nearest this step's reference pose."""
    q = obs.state[..., : targets.shape[-1]]  # s_t starts with the hand's joint positions
    return jnp.clip((replay(targets, obs, key) - q) / alpha, -1.0, 1.0)


def tracking_delta_controller(task: PullTask) -> Controller:
    """The expert drag through the action interface (deterministic, like ``tracking``)."""
    policy = functools.partial(increments, task.config.alpha)
    return Controller(TRACKING_DELTA, lambda deterministic: policy, jnp.asarray(drag_targets(task)),
                      key=TRACKING_DELTA)
