"""Trajectory-tracking baseline (paper Table 2, row 1; Appendix A.2): each next reference hand pose of the
drag phase becomes the hand PD target; the object state is never replayed, so the part opens only if the
replayed hand motion drags it through contact. It is a controller of the evaluator (``controls="targets"``):
the same cells and metric names as every policy. After the drag block it holds the last pose."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.evaluation.evaluate import Controller, make_rollout
from dragmesh2_jax.task.env import Obs, PullTask

TRACKING = "tracking"


def drag_targets(task: PullTask) -> np.ndarray:
    """Hand targets, one per control step: the frames after the drag start through the end of the first
    contiguous drag block, each held for frame_dt / control_dt steps (1 for ours, 2 for the reference's
    30 Hz files)."""
    traj = task.traj
    frame_dt = traj.header.get("scene", {}).get("frame_dt", 1.0 / 30.0)
    hold = max(1, int(round(frame_dt / task.config.control_dt)))
    start = traj.drag_start
    end = next((b for p, a, b in traj.phase_blocks() if p == "drag" and a == start), len(traj.frames))
    frames = [traj.frames[i].hand_target or traj.frames[i].hand_q for i in range(start + 1, end)]
    return np.repeat(np.asarray(frames, np.float32), hold, axis=0)


def replay(targets: jnp.ndarray, obs: Obs, key) -> jnp.ndarray:
    """The PD target of the episode's current step (the last one once the replay is over)."""
    return targets[jnp.minimum(obs.step, targets.shape[0] - 1)]


def tracking_controller(task: PullTask) -> Controller:
    """The expert drag replayed open-loop (deterministic: det and stoch are the same controller)."""
    return Controller(TRACKING, lambda deterministic: replay, jnp.asarray(drag_targets(task)), controls="targets",
                      key=TRACKING)


def track(task: PullTask, dampings: list[float], episodes: int = 1, seed: int = 0) -> list[dict]:
    """The evaluator's cells of the tracking baseline on ``task`` (its own starts: exact unless the config
    perturbs them) at each damping multiplier."""
    c = tracking_controller(task)
    return make_rollout(task, replay, dampings, episodes, c.controls, key=c.key)(c.params, seed)
