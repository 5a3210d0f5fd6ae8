"""Evaluation protocol (paper §4, Appendix A.2, eq. robust): for each damping multiplier x mode (det = Gaussian
mean, stoch = sample), ``episodes`` episodes from the expert grasp, all run as parallel worlds in one rollout.

Per cell: success_rate, progress_mean (final progress), return_mean, steps_mean, clip099 (fraction of steps
whose max |a_i| exceeds 0.99), detach_rate, action_l2_mean. Robustness per mode: mean and worst success
over the damping set.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.ppo.train import Trainer, TrainState

MODES = ("det", "stoch")


def evaluate(trainer: Trainer, ts: TrainState, dampings: list[float], modes: list[str], episodes: int = 20,
             seed: int = 42) -> dict:
    task = trainer.task
    cells = [(d, m) for d in dampings for m in modes]
    n = len(cells) * episodes
    scales = jnp.asarray(np.repeat([d for d, _ in cells], episodes), jnp.float32)
    stoch = jnp.asarray(np.repeat([m == "stoch" for _, m in cells], episodes))
    T = task.config.episode_length

    @jax.jit
    def run(params, ts, key):
        k_env, k_act = jax.random.split(key)
        state = trainer.reset(jax.random.split(k_env, n), scales)
        zeros = jnp.zeros(n)

        def body(carry, k):
            state, live, acc = carry
            mu, log_std, _, _ = trainer.apply(params, ts, state.obs)
            a = jnp.where(stoch[:, None], mu + jnp.exp(log_std) * jax.random.normal(k, mu.shape), mu)
            state = trainer.step(state, a)
            m = state.metrics
            ac = jnp.clip(a, -1, 1)
            acc = {
                "steps": acc["steps"] + live, "clip": acc["clip"] + live * (jnp.max(jnp.abs(ac), -1) > 0.99),
                "l2": acc["l2"] + live * m["action_l2"],
                "success": jnp.where(live, m["success"], acc["success"]),
                "detach": jnp.where(live, m["detach"], acc["detach"]),
                "progress": jnp.where(live, m["progress"], acc["progress"]),
                "ret": jnp.where(live, m["episode_return"], acc["ret"]),
            }
            return (state, live & ~state.done, acc), None

        acc0 = {k: zeros for k in ("steps", "clip", "l2", "success", "detach", "progress", "ret")}
        (_, _, acc), _ = jax.lax.scan(body, (state, jnp.ones(n, bool), acc0), jax.random.split(k_act, T))
        return acc

    acc = jax.device_get(run(ts.params, ts, jax.random.PRNGKey(seed)))
    records = []
    for i, (d, m) in enumerate(cells):
        sl = slice(i * episodes, (i + 1) * episodes)
        steps = acc["steps"][sl]
        records.append({
            "damping": float(d), "mode": m, "episodes": episodes,
            "success_rate": float(np.mean(acc["success"][sl] > 0)),
            "progress_mean": float(np.mean(acc["progress"][sl])),
            "return_mean": float(np.mean(acc["ret"][sl])), "steps_mean": float(np.mean(steps)),
            "clip099": float(acc["clip"][sl].sum() / max(steps.sum(), 1)),
            "detach_rate": float(np.mean(acc["detach"][sl] > 0)),
            "action_l2_mean": float(acc["l2"][sl].sum() / max(steps.sum(), 1)),
        })
    robust = {}
    for m in modes:
        s = [r["success_rate"] for r in records if r["mode"] == m]
        robust[m] = {"mean_success": float(np.mean(s)), "worst_success": float(np.min(s))}
    return {"cells": records, "robustness": robust, "object_id": task.scene.obj.object_id,
            "method": trainer.method.name, "backend": task.backend.name}


def markdown_table(result: dict) -> str:
    lines = ["| damping | mode | success | progress | return | steps | clip099 | detach | action L2 |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in result["cells"]:
        lines.append(f"| x{r['damping']:g} | {r['mode']} | {r['success_rate']:.2f} | {r['progress_mean']:.2f} | "
                     f"{r['return_mean']:.1f} | {r['steps_mean']:.1f} | {r['clip099']:.3f} | {r['detach_rate']:.2f} | "
                     f"{r['action_l2_mean']:.2f} |")
    lines += ["", "| mode | mean success | worst success |", "|---|---|---|"]
    for m, v in result["robustness"].items():
        lines.append(f"| {m} | {v['mean_success']:.2f} | {v['worst_success']:.2f} |")
    return "\n".join(lines)
