"""Which of a residual policy's channels loses the part? The run's policy rolled out (det, from the evaluation's
perturbed starts) with its output on one group of channels scaled at evaluation only (the wrist's translation, its
rotation, the fingers; 0: that group's residual off, its expert's drag alone), beside the policy as trained.

    python experiments/residual_channels.py RUN --damping 8 --episodes 20 --scale 0 0.25

A diagnostic, not a judged run: the policy was not trained with the group narrowed.
"""

from __future__ import annotations

import argparse
import json

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.assets.hand import NUM_DOFS, NUM_VIRTUAL
from dragmesh2_jax.evaluation.protocol import PAPER
from dragmesh2_jax.ppo.train import policy_params
from dragmesh2_jax.runs.commands import load_run

GROUPS = {"translation": range(3), "rotation": range(3, NUM_VIRTUAL), "fingers": range(NUM_VIRTUAL, NUM_DOFS)}


def rollouts(run: str, damping: float, episodes: int, gains: dict[str, np.ndarray]) -> dict[str, dict]:
    """Per named gain (one factor per action channel): success, steps, wrist load and palm speed p95 over episodes."""
    program, ts, _, _ = load_run(run, "mujoco")
    task = PAPER.task(program.task)
    policy, params = program.make_policy(True), policy_params(ts)
    reset, step = jax.vmap(task.reset), jax.vmap(task.step)
    scales = jnp.full((episodes,), damping, jnp.float32)

    @jax.jit
    def roll(gain, key):
        def body(carry, _):
            state, live = carry
            k0 = jax.vmap(task.kinematics)(state)
            state = step(state, jnp.clip(policy(params, state.obs, key), -1, 1) * gain)
            k = jax.vmap(task.kinematics)(state)
            speed = jnp.linalg.norm(k.palm - k0.palm, axis=-1) / task.config.control_dt
            return (state, live & ~state.done), (speed, jnp.linalg.norm(k.force[:, :3], axis=-1), live,
                                                 state.metrics["success"])

        start = reset(jax.random.split(key, episodes), scales)
        return jax.lax.scan(body, (start, jnp.ones(episodes, bool)), None, length=task.config.episode_length)[1]

    rows = {}
    for name, gain in gains.items():
        speed, wrist, live, success = jax.device_get(roll(jnp.asarray(gain), jax.random.PRNGKey(0)))
        rows[name] = {"success_rate": float((success * live).max(0).mean()), "steps_mean": float(live.sum(0).mean()),
                      "wrist_load_p95_n": float(np.percentile((wrist * live).max(0), 95)),
                      "palm_speed_p95_m_s": float(np.percentile((speed * live).max(0), 95))}
    return rows


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run")
    p.add_argument("--damping", type=float, default=8.0)
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--scale", type=float, nargs="+", default=[0.0], help="factors on one group at a time")
    args = p.parse_args()
    gains = {"as trained": np.ones(NUM_DOFS, np.float32)}
    for group, idx in GROUPS.items():
        for f in args.scale:
            gains[f"{group} x{f:g}"] = np.where(np.isin(np.arange(NUM_DOFS), list(idx)), f, 1.0).astype(np.float32)
    for name, row in rollouts(args.run, args.damping, args.episodes, gains).items():
        print(json.dumps({"run": args.run, "damping": args.damping, "residual": name, **row}), flush=True)


if __name__ == "__main__":
    main()
