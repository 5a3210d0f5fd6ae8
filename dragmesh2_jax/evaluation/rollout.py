"""The one rollout of the evaluator: ``len(dampings) * episodes`` worlds of a task under a policy, each world's damping
multiplier fixed and the episodes of a cell each from its own start of the task's bank (the first ``episodes``), all
in one compiled program. Cells, traces and video frames are views of its result.

Without ``steps`` it runs until every world has finished its first episode (at most the episode length) and returns
per-world accumulations of that first episode (:func:`cells` reads them). With ``steps`` it runs exactly that many
control steps and also records, per step and world, the object q, the effector q and the load sensors (wrist force
and torque, touch) before the step, the policy's action and whether the first episode has ended (:func:`trace` and
:func:`frames` read those); a world whose episode ended keeps stepping from its final state (no reset), counted nowhere.

Compiled rollouts are shared: with a controller ``key`` (what the policy depends on besides its params) and the
task's signature, every object, checkpoint and seed of the same structure reuses one program (jax's own cache,
the rollout's description a static argument).
"""

from __future__ import annotations

import functools
from collections.abc import Hashable
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.policies.controller import Policy
from dragmesh2_jax.task.env import PullTask, TaskData, applied_action
from dragmesh2_jax.task.protocol import CLIP_LEVEL, START_STEPS

ACCUMULATED = ("steps", "clip", "clip_active", "clip_policy", "l2", "success", "detach", "progress", "ret", "overflow",
               "load_peak", "palm_speed_peak", "palm_speed_settled_peak", "part_speed_peak", "penetration_max",
               "penetration_settled", "change")


@dataclass(frozen=True, eq=False)
class Rollout:
    """What a compiled rollout depends on (hashable by it when ``key`` is given, else by identity)."""

    task: PullTask
    policy: Policy
    scales: tuple[float, ...]  # one damping multiplier per world
    episodes: int  # per damping: world w starts from start w % episodes of the task's bank (each its own)
    controls: str = "actions"
    steps: int | None = None
    key: Hashable | None = None

    def _id(self):
        return id(self) if self.key is None else (self.key, self.task.signature(), self.scales, self.episodes,
                                                  self.controls, self.steps)

    def __hash__(self):
        return hash(self._id())

    def __eq__(self, other):
        return isinstance(other, Rollout) and self._id() == other._id()


@functools.partial(jax.jit, static_argnums=0)
def _run(r: Rollout, data: TaskData, params: Any, key: jax.Array) -> dict:
    task = r.task.bind(data)
    n = len(r.scales)
    reset = jax.vmap(task.reset)
    step = jax.vmap(task.step_target if r.controls == "targets" else task.step)
    kinematics = jax.vmap(task.kinematics)
    k_env, k_act = jax.random.split(key)
    state = reset(jax.random.split(k_env, n), jnp.asarray(r.scales, jnp.float32), jnp.arange(n) % r.episodes)
    acc0 = {k: jnp.zeros(n) for k in ACCUMULATED}

    def body(state, live, acc, key):
        key, k = jax.random.split(key)
        u = r.policy(params, state.obs, k)
        u = u if r.controls == "targets" else jnp.clip(u, -1.0, 1.0)
        before, prev = kinematics(state), applied_action(state.obs, task.action_size)
        state = step(state, u)
        after = kinematics(state)
        m = state.metrics
        a = applied_action(state.obs, task.action_size)
        dt = task.config.control_dt

        palm_speed, settled = jnp.linalg.norm(after.palm - before.palm, axis=-1) / dt, acc["steps"] >= START_STEPS

        def peak(name, value, when=True):
            return jnp.where(live & when, jnp.maximum(acc[name], value), acc[name])

        acc = {
            "steps": acc["steps"] + live, "l2": acc["l2"] + live * m["action_l2"],
            "clip": acc["clip"] + live * (m["action_abs_max"] > CLIP_LEVEL),
            "clip_active": acc["clip_active"] + live * (m["active_abs_max"] > CLIP_LEVEL),
            # the policy's own output, before a residual adds to the expert's (a target controller's: what it applied)
            "clip_policy": acc["clip_policy"] + live * (
                m["active_abs_max"] if r.controls == "targets" else jnp.max(jnp.where(task.active, jnp.abs(u), 0.0), -1)
            > CLIP_LEVEL),
            "overflow": acc["overflow"] + live * m["overflow"],
            "load_peak": peak("load_peak", jnp.linalg.norm(before.force[:, :3], axis=-1)),
            "palm_speed_peak": peak("palm_speed_peak", palm_speed),
            "palm_speed_settled_peak": peak("palm_speed_settled_peak", palm_speed, settled),
            "part_speed_peak": peak("part_speed_peak", jnp.abs(after.obj_q - before.obj_q) / dt),
            "penetration_max": peak("penetration_max", after.penetration),
            "penetration_settled": peak("penetration_settled", after.penetration, settled),
            "change": acc["change"] + live * (acc["steps"] > 0) * jnp.mean(jnp.abs(a - prev), axis=-1),
            **{k: jnp.where(live, m[src], acc[k]) for k, src in (
                ("success", "success"), ("detach", "detach"), ("progress", "progress"), ("ret", "episode_return"))},
        }
        record = {"q": m["q"], "hand_q": before.hand_q, "obj_q": before.obj_q, "live": live, "force": before.force,
                  "policy": u}
        return state, live & ~state.done, acc, key, record

    live0 = jnp.ones(n, bool)
    if r.steps is None:
        def loop(c):
            t, state, live, acc, key = c
            state, live, acc, key, _ = body(state, live, acc, key)
            return t + 1, state, live, acc, key

        T = task.config.episode_length
        _, _, _, acc, _ = jax.lax.while_loop(lambda c: (c[0] < T) & c[2].any(), loop,
                                             (jnp.int32(0), state, live0, acc0, k_act))
        return {"acc": acc}

    def scan_body(c, _):
        state, live, acc, key, record = body(*c)
        return (state, live, acc, key), record

    (_, _, acc, _), records = jax.lax.scan(scan_body, (state, live0, acc0, k_act), None, length=r.steps)
    return {"acc": acc, **records}


def rollout(task: PullTask, policy: Policy, params: Any, dampings: list[float], episodes: int = 1, seed: int = 0,
            controls: str = "actions", steps: int | None = None, key: Hashable | None = None) -> dict:
    """Run the rollout; host arrays: ``acc`` (per-world accumulations, see :func:`cells`) and with ``steps`` the
    per-step records ``q``, ``hand_q``, ``obj_q``, ``force`` (the load sensors), ``wrist_load`` (N), ``live`` and
    ``policy`` (the policy's own action, before a residual adds to the expert's) (steps x worlds [x DoFs])."""
    r = Rollout(task, policy, tuple(float(d) for d in np.repeat(dampings, episodes)), episodes, controls, steps, key)
    out = jax.tree.map(np.asarray, jax.device_get(_run(r, task.sized(len(r.scales)).data, params,
                                                       jax.random.PRNGKey(seed))))
    task.check_overflow(int(out["acc"]["overflow"].sum()), "evaluation")
    if steps is not None:
        out["wrist_load"] = np.linalg.norm(out["force"][..., :3], axis=-1)
    return out


def wilson_interval(successes: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """The Wilson score interval of a binomial rate (good at 0 and 1, unlike the normal approximation); ``z``: the
    two-sided 95% normal quantile."""
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * (p * (1 - p) / n + z * z / (4 * n * n)) ** 0.5 / denom
    return max(0.0, centre - half), min(1.0, centre + half)


#: The percentile over a cell's episodes of each episode's peak, for the peaks a cell reports (robust to one
#: episode's spike, as ``envelope`` reports one episode's peak).
PEAK_PERCENTILE = 95


def cells(result: dict, dampings: list[float], episodes: int) -> list[dict]:
    """Per damping cell, over the first episode of every world of the cell: success_rate with its 95% Wilson
    interval, progress_mean (final progress), return_mean, steps_mean (episode length), clip099 over every action
    channel and clip099_active over the DoFs that move (the applied action), clip099_policy_active the same of the
    policy's own output (a residual's before it adds to the expert's: the saturation the policy chose),
    detach_rate, action_l2_mean; and how it was done, physically: wrist_load_peak_n, palm_speed_peak_m_s (and
    palm_speed_settled_peak_m_s, from the step after the first START_STEPS on) and part_speed_peak (joint units per
    second), each the 95th percentile over the episodes of each episode's peak; penetration_max_mm, the deepest
    hand-object penetration of any episode, penetration_p95_mm the 95th percentile over the episodes of each one's
    deepest, and penetration_settled_p95_mm the same from the step after the first START_STEPS; action_smoothness,
    the mean |a_t - a_(t-1)| over channels and steps (action units)."""
    acc = result["acc"]
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
            "clip099_policy_active": float(acc["clip_policy"][sl].sum() / total),
            "detach_rate": float(np.mean(acc["detach"][sl] > 0)),
            "action_l2_mean": float(acc["l2"][sl].sum() / total),
            "wrist_load_peak_n": float(np.percentile(acc["load_peak"][sl], PEAK_PERCENTILE)),
            "palm_speed_peak_m_s": float(np.percentile(acc["palm_speed_peak"][sl], PEAK_PERCENTILE)),
            "palm_speed_settled_peak_m_s": float(np.percentile(acc["palm_speed_settled_peak"][sl], PEAK_PERCENTILE)),
            "part_speed_peak": float(np.percentile(acc["part_speed_peak"][sl], PEAK_PERCENTILE)),
            "penetration_max_mm": float(1000.0 * acc["penetration_max"][sl].max()),
            "penetration_p95_mm": float(1000.0 * np.percentile(acc["penetration_max"][sl], PEAK_PERCENTILE)),
            "penetration_settled_p95_mm": float(1000.0 * np.percentile(acc["penetration_settled"][sl],
                                                                       PEAK_PERCENTILE)),
            "action_smoothness": float(acc["change"][sl].sum() / max(float(np.maximum(steps - 1, 0).sum()), 1.0)),
        })
    return records


def trace(result: dict) -> dict:
    """Per world: whether its first episode succeeded (``success``), and each step's object q (``q``: steps x n),
    effector q and load sensors before the step (``hand_q``, ``force``: steps x n x size)."""
    return {"success": result["acc"]["success"] > 0, "q": result["q"], "hand_q": result["hand_q"],
            "force": result["force"]}


def frames(result: dict, dampings: list[float]) -> list[dict]:
    """Per world (one per damping): the effector and object q and the wrist load (N) of every step of its first
    episode, how it ended and its length (what a video shows)."""
    rows = []
    for i, d in enumerate(dampings):
        steps = int(result["live"][:, i].sum())
        rows.append({"damping": float(d), "hand_q": result["hand_q"][:steps, i], "obj_q": result["obj_q"][:steps, i],
                     "wrist_load": result["wrist_load"][:steps, i], "success": bool(result["acc"]["success"][i] > 0),
                     "detach": bool(result["acc"]["detach"][i] > 0), "steps": steps})
    return rows
