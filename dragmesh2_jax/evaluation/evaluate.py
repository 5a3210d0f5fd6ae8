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

Anything that maps observations to controls evaluates here, through one rollout with one set of metric names: a
policy is ``policy(params, obs, key) -> action`` (Brax's ``make_inference_fn``), packed with its parameters as a
:class:`Controller` (``Trainer.controller``, ``baselines.tracking.tracking_controller``,
``baselines.brax_ppo.brax_controller``).
"""

from __future__ import annotations

import collections
import dataclasses
import math
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.ppo.train import CLIP_LEVEL
from dragmesh2_jax.task.env import Obs, PullTask

MODES = ("det", "stoch")
Z95 = 1.959964  # two-sided 95% normal quantile
Policy = Callable[[Any, Obs, jax.Array], jnp.ndarray]
CONTROLS = ("actions", "targets")


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a binomial rate (good at 0 and 1, unlike the normal approximation)."""
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)


@dataclass(frozen=True)
class Controller:
    """What the evaluator runs: ``make_policy(deterministic) -> Policy`` with its ``params``. ``controls`` says what
    the policy outputs: ``"actions"`` (a in [-1, 1]^51, target = q_hand + alpha a: every learned policy) or
    ``"targets"`` (the hand PD targets themselves: scripted controllers such as the tracking baseline)."""

    name: str
    make_policy: Callable[[bool], Policy]
    params: Any
    controls: str = "actions"
    key: Hashable | None = None  # what make_policy's functions depend on besides params: shares compiled rollouts

    def __post_init__(self):
        if self.controls not in CONTROLS:
            raise ValueError(f"controls must be one of {CONTROLS}, got {self.controls!r}")


def make_rollout(task: PullTask, policy: Policy, dampings: list[float], episodes: int, controls: str = "actions",
                 key: Hashable | None = None):
    """``(params, seed) -> per-cell metrics``: one jitted rollout of ``len(dampings) * episodes`` worlds under
    ``policy``, compiled once and reusable (the in-training robustness check calls it every few epochs). The
    object's data is an argument of the program, so with ``key`` (what ``policy`` depends on besides its params,
    e.g. ``Trainer.signature()``) every object, checkpoint and seed of the same structure shares one compiled
    rollout."""
    cache_key = None if key is None else (key, task.signature(), tuple(dampings), episodes, controls)
    if cache_key is None or cache_key not in _ROLLOUTS:
        run = _compile_rollout(task, policy, dampings, episodes, controls)
        if cache_key is None:
            return _cells(run, task, dampings, episodes)
        _ROLLOUTS[cache_key] = run
        while len(_ROLLOUTS) > ROLLOUT_CACHE_SIZE:
            _ROLLOUTS.popitem(last=False)
    _ROLLOUTS.move_to_end(cache_key)
    return _cells(_ROLLOUTS[cache_key], task, dampings, episodes)


ROLLOUT_CACHE_SIZE = 16  # compiled evaluation rollouts kept
_ROLLOUTS: collections.OrderedDict[tuple, Any] = collections.OrderedDict()


def _compile_rollout(template: PullTask, policy: Policy, dampings: list[float], episodes: int, controls: str):
    n = len(dampings) * episodes
    scales = jnp.asarray(np.repeat(dampings, episodes), jnp.float32)
    T = template.config.episode_length

    @jax.jit
    def run(data, params, key):
        task = template.bind(data)
        reset = jax.vmap(task.reset)
        step = jax.vmap(task.step_target if controls == "targets" else task.step)
        k_env, k_act = jax.random.split(key)
        state = reset(jax.random.split(k_env, n), scales)
        zeros = jnp.zeros(n)
        acc0 = {k: zeros for k in ("steps", "clip", "clip_active", "l2", "success", "detach", "progress", "ret")}

        def body(carry):
            t, state, live, acc, key = carry
            key, k = jax.random.split(key)
            u = policy(params, state.obs, k)
            state = step(state, u if controls == "targets" else jnp.clip(u, -1.0, 1.0))
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

    return run


def _cells(run, task: PullTask, dampings: list[float], episodes: int):
    def cells(params: Any, seed: int = 42) -> list[dict]:
        return _cell_records(jax.device_get(run(task.data, params, jax.random.PRNGKey(seed))), dampings, episodes)

    return cells


def trace_rollout(task: PullTask, controller: Controller, dampings: list[float], steps: int, seed: int = 0) -> dict:
    """A fixed-length rollout, one world per damping, of ``controller``'s deterministic policy (backend parity
    checks): per world, whether it succeeded before its first episode ended (``success``), and each step's object
    q (``q``: steps x n) and effector q (``hand_q``: steps x n x DoFs)."""
    policy = controller.make_policy(True)
    targets = controller.controls == "targets"
    step = jax.vmap(task.step_target if targets else task.step)
    n = len(dampings)

    @jax.jit
    def run(params, keys, scales, key):
        state = jax.vmap(task.reset)(keys, scales)

        def body(carry, _):
            state, finished, success, key = carry
            key, k = jax.random.split(key)
            u = policy(params, state.obs, k)
            state = step(state, u if targets else jnp.clip(u, -1.0, 1.0))
            success = success | (~finished & (state.metrics["success"] > 0))
            return (state, finished | state.done, success, key), (state.metrics["q"],
                                                                   state.obs.state[:, :task.action_size])

        init = (state, jnp.zeros(n, bool), jnp.zeros(n, bool), key)
        (_, _, success, _), (q, hand_q) = jax.lax.scan(body, init, None, length=steps)
        return success, q, hand_q

    k_env, k_act = jax.random.split(jax.random.PRNGKey(seed))
    success, q, hand_q = jax.device_get(run(controller.params, jax.random.split(k_env, n),
                                            jnp.asarray(dampings, jnp.float32), k_act))
    return {"success": np.asarray(success), "q": np.asarray(q), "hand_q": np.asarray(hand_q)}


def rollout_cells(task: PullTask, policy: Policy, params: Any, dampings: list[float], episodes: int,
                  seed: int = 42, controls: str = "actions", key: Hashable | None = None) -> list[dict]:
    """One rollout of ``len(dampings) * episodes`` worlds under ``policy``; per-cell metrics (no mode)."""
    return make_rollout(task, policy, dampings, episodes, controls, key=key)(params, seed)


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


def evaluate(task: PullTask, controller: Controller, dampings: list[float], modes: list[str], episodes: int = 20,
             seed: int = 42) -> dict:
    """The protocol for any controller (a trained policy, a baseline, a scripted primitive): every (damping, mode)
    cell on ``task``, with one set of metric names."""
    cells = []
    for m in modes:
        policy = controller.make_policy(m == "det")
        key = None if controller.key is None else (controller.key, m)
        cells += [{**r, "mode": m} for r in rollout_cells(task, policy, controller.params, dampings, episodes, seed,
                                                           controller.controls, key)]
    noise = task.config.reset_noise
    return {"cells": cells, "robustness": robustness(cells, modes), "object_id": task.scene.obj.object_id,
            "method": controller.name, "backend": task.backend.name,
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
