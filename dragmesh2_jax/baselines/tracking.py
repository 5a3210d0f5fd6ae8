"""Trajectory-tracking baseline (paper Table 2, row 1; Appendix A.2): each next reference hand pose of the
drag phase becomes the hand PD target; the object state is never replayed, so the part opens only if the
replayed hand motion drags it through contact. One world per damping multiplier, all in one jitted scan."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.assets.hand import NUM_DOFS
from dragmesh2_jax.task.env import PullTask


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


def track(task: PullTask, dampings: list[float], seed: int = 0, traces: bool = False):
    """Success (q reached q_done at any step) and final progress per damping multiplier. With ``traces``,
    also the per-step object q (T, n) and hand q (T, n, 51) of the rollout (for backend parity checks)."""
    targets = jnp.asarray(drag_targets(task))
    n = len(dampings)
    keys = jax.random.split(jax.random.PRNGKey(seed), n)
    scales = jnp.asarray(dampings, jnp.float32)

    @jax.jit
    def run(keys, scales):
        state = jax.vmap(task.reset)(keys, scales)

        def body(carry, target):
            state, finished, success, progress = carry
            state = jax.vmap(task.step_target)(state, jnp.broadcast_to(target, (n, NUM_DOFS)))
            m = state.metrics
            live = ~finished
            success = success | (live & (m["success"] > 0))
            progress = jnp.where(live, m["progress"], progress)
            finished = finished | state.done
            return (state, finished, success, progress), (m["q"], state.obs.state[:, :51])

        init = (state, jnp.zeros(n, bool), jnp.zeros(n, bool), jnp.zeros(n, jnp.float32))
        (_, _, success, progress), qs = jax.lax.scan(body, init, targets)
        return success, progress, qs

    success, progress, (qs, hand) = run(keys, scales)
    rows = [{"damping": float(d), "success": bool(s), "final_progress": float(p), "q_max": float(q)}
            for d, s, p, q in zip(dampings, np.asarray(success), np.asarray(progress), np.asarray(qs).max(0),
                                  strict=True)]
    return (rows, {"q": np.asarray(qs), "hand_q": np.asarray(hand)}) if traces else rows
