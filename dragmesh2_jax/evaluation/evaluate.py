"""Evaluation (paper §4, Appendix A.2, eq. robust): a controller over the damping x mode cells of an
:class:`~dragmesh2_jax.evaluation.protocol.EvalProtocol`, each cell's episodes parallel worlds of one rollout
(``evaluation/rollout.py``). Robustness per mode: mean and worst success over the damping set.

Anything that maps observations to controls evaluates here with one set of metric names: a
:class:`~dragmesh2_jax.policies.controller.Controller` (a trained run's, the tracking baselines, brax's policies,
the parallel-jaw primitive).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from dragmesh2_jax.baselines.tracking import tracking_controller
from dragmesh2_jax.evaluation.protocol import EvalProtocol
from dragmesh2_jax.evaluation.rollout import cells, rollout
from dragmesh2_jax.policies.controller import Controller
from dragmesh2_jax.task.env import PullTask


def robustness(records: list[dict], modes: list[str]) -> dict:
    """Paper eq. robust: mean and worst success over the damping set, per mode (plus mean active clip099)."""
    out = {}
    for m in modes:
        rs = [r for r in records if r["mode"] == m]
        s = [r["success_rate"] for r in rs]
        out[m] = {"mean_success": float(np.mean(s)), "worst_success": float(np.min(s)),
                  "clip099_active": float(np.mean([r["clip099_active"] for r in rs]))}
    return out


def evaluate(task: PullTask, controller: Controller, protocol: EvalProtocol) -> dict:
    """Every (damping, mode) cell of ``protocol`` on ``task`` (the protocol's task: ``protocol.task(...)``, or a
    controller's own task with the protocol's starts)."""
    if task.config.reset_noise != protocol.starts:
        raise ValueError("evaluate needs the protocol's starts (build the task with protocol.task(task))")
    dampings = list(protocol.dampings)
    records = []
    for m in protocol.modes:
        key = None if controller.key is None else (controller.key, m)
        result = rollout(task, controller.make_policy(m == "det"), controller.params, dampings, protocol.episodes,
                         protocol.seed, controller.controls, key=key)
        records += [{**r, "mode": m} for r in cells(result, dampings, protocol.episodes)]
    return {"cells": records, "robustness": robustness(records, list(protocol.modes)),
            "object_id": task.scene.obj.object_id, "method": controller.name, "backend": task.backend.name,
            "protocol": dataclasses.asdict(protocol)}


def track(task: PullTask, dampings: list[float], episodes: int = 1, seed: int = 0) -> list[dict]:
    """The cells of the tracking baseline on ``task`` (its own starts: exact unless its config perturbs them) at
    each damping multiplier."""
    c = tracking_controller(task)
    return cells(rollout(task, c.make_policy(True), c.params, dampings, episodes, seed, c.controls, key=c.key),
                 dampings, episodes)


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
