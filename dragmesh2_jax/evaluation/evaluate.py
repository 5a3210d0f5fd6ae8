"""Evaluation protocol (paper §4, Appendix A.2, eq. robust): for each damping multiplier x mode (det = Gaussian
mean, stoch = sample), ``episodes`` episodes, all run as parallel worlds of one rollout that stops as soon as
every world has finished its first episode.

Starts: by default each episode starts from a perturbed expert grasp (``EVAL_RESET_NOISE``: a seeded bank of
starts, see ``ResetNoise``), so a deterministic cell is a distribution over starts and its success is a rate;
``exact_reset`` keeps the paper's noise-free protocol (then a det cell is one episode repeated).

Per cell: success_rate with its 95% Wilson interval, progress_mean (final progress), return_mean, steps_mean
(episode length), clip099 over all 51 action channels and clip099_active over the 27 DoFs that move (the 24
locked finger axes take actions that move nothing), detach_rate, action_l2_mean. Robustness per mode: mean and
worst success over the damping set.

Anything that maps observations to actions evaluates here: a policy is ``policy(params, obs, key) -> action``
(see ``Trainer.make_policy``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.ppo.train import CLIP_LEVEL
from dragmesh2_jax.task.env import Obs, PullTask

MODES = ("det", "stoch")
Z95 = 1.959964  # two-sided 95% normal quantile
Policy = Callable[[Any, Obs, jax.Array], jnp.ndarray]


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a binomial rate (good at 0 and 1, unlike the normal approximation)."""
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)


def make_rollout(task: PullTask, policy: Policy, dampings: list[float], episodes: int):
    """``(params, seed) -> per-cell metrics``: one jitted rollout of ``len(dampings) * episodes`` worlds under
    ``policy``, compiled once and reusable (the in-training robustness check calls it every few epochs)."""
    n = len(dampings) * episodes
    scales = jnp.asarray(np.repeat(dampings, episodes), jnp.float32)
    T = task.config.episode_length
    reset, step = jax.vmap(task.reset), jax.vmap(task.step)

    @jax.jit
    def run(params, key):
        k_env, k_act = jax.random.split(key)
        state = reset(jax.random.split(k_env, n), scales)
        zeros = jnp.zeros(n)
        acc0 = {k: zeros for k in ("steps", "clip", "clip_active", "l2", "success", "detach", "progress", "ret")}

        def body(carry):
            t, state, live, acc, key = carry
            key, k = jax.random.split(key)
            a = jnp.clip(policy(params, state.obs, k), -1.0, 1.0)
            state = step(state, a)
            m = state.metrics
            acc = {
                "steps": acc["steps"] + live, "l2": acc["l2"] + live * m["action_l2"],
                "clip": acc["clip"] + live * (m["action_abs_max"] > CLIP_LEVEL),
                "clip_active": acc["clip_active"] + live * (m["active_abs_max"] > CLIP_LEVEL),
                **{k: jnp.where(live, m[src], acc[k]) for k, src in (
                    ("success", "success"), ("detach", "detach"), ("progress", "progress"),
                    ("ret", "episode_return"))},
            }
            return t + 1, state, live & ~state.done, acc, key

        init = (jnp.int32(0), state, jnp.ones(n, bool), acc0, k_act)
        _, _, _, acc, _ = jax.lax.while_loop(lambda c: (c[0] < T) & c[2].any(), body, init)
        return acc

    def cells(params: Any, seed: int = 42) -> list[dict]:
        return _cell_records(jax.device_get(run(params, jax.random.PRNGKey(seed))), dampings, episodes)

    return cells


def rollout_cells(task: PullTask, policy: Policy, params: Any, dampings: list[float], episodes: int,
                  seed: int = 42) -> list[dict]:
    """One rollout of ``len(dampings) * episodes`` worlds under ``policy``; per-cell metrics (no mode)."""
    return make_rollout(task, policy, dampings, episodes)(params, seed)


def _cell_records(acc: dict, dampings: list[float], episodes: int) -> list[dict]:
    records = []
    for i, d in enumerate(dampings):
        sl = slice(i * episodes, (i + 1) * episodes)
        steps = acc["steps"][sl]
        wins = int(np.sum(acc["success"][sl] > 0))
        lo, hi = wilson_interval(wins, episodes)
        total = max(float(steps.sum()), 1.0)
        records.append({
            "damping": float(d), "episodes": episodes, "successes": wins, "success_rate": wins / episodes,
            "success_ci95": [lo, hi], "progress_mean": float(np.mean(acc["progress"][sl])),
            "return_mean": float(np.mean(acc["ret"][sl])), "steps_mean": float(np.mean(steps)),
            "clip099": float(acc["clip"][sl].sum() / total),
            "clip099_active": float(acc["clip_active"][sl].sum() / total),
            "detach_rate": float(np.mean(acc["detach"][sl] > 0)),
            "action_l2_mean": float(acc["l2"][sl].sum() / total),
        })
    return records


def robustness(cells: list[dict], modes: list[str]) -> dict:
    """Paper eq. robust: mean and worst success over the damping set, per mode (plus mean active clip099)."""
    out = {}
    for m in modes:
        rs = [r for r in cells if r["mode"] == m]
        s = [r["success_rate"] for r in rs]
        out[m] = {"mean_success": float(np.mean(s)), "worst_success": float(np.min(s)),
                  "clip099_active": float(np.mean([r["clip099_active"] for r in rs]))}
    return out


def evaluate(trainer, ts, dampings: list[float], modes: list[str], episodes: int = 20, seed: int = 42,
             task: PullTask | None = None) -> dict:
    """The protocol for a trained policy: every (damping, mode) cell on ``task`` (default: the trainer's)."""
    task = task or trainer.task
    params = trainer.policy_params(ts)
    cells = []
    for m in modes:
        policy = trainer.make_policy(deterministic=m == "det")
        cells += [{**r, "mode": m} for r in rollout_cells(task, policy, params, dampings, episodes, seed)]
    noise = task.config.reset_noise
    return {"cells": cells, "robustness": robustness(cells, modes), "object_id": task.scene.obj.object_id,
            "method": trainer.method.name, "backend": task.backend.name,
            "starts": "exact" if noise is None else dataclasses.asdict(noise)}


def markdown_table(result: dict) -> str:
    lines = ["| damping | mode | success [95% CI] | progress | return | steps | clip099 | clip099 active | detach | "
             "action L2 |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in result["cells"]:
        lo, hi = r["success_ci95"]
        lines.append(f"| x{r['damping']:g} | {r['mode']} | {r['success_rate']:.2f} [{lo:.2f}, {hi:.2f}] | "
                     f"{r['progress_mean']:.2f} | {r['return_mean']:.1f} | {r['steps_mean']:.1f} | "
                     f"{r['clip099']:.3f} | {r['clip099_active']:.3f} | {r['detach_rate']:.2f} | "
                     f"{r['action_l2_mean']:.2f} |")
    lines += ["", "| mode | mean success | worst success | clip099 active |", "|---|---|---|---|"]
    for m, v in result["robustness"].items():
        lines.append(f"| {m} | {v['mean_success']:.2f} | {v['worst_success']:.2f} | {v['clip099_active']:.3f} |")
    return "\n".join(lines)
