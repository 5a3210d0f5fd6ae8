"""Evaluation (paper §4, Appendix A.2, eq. robust): a controller over the damping x mode cells of an
:class:`~dragmesh2_jax.evaluation.protocol.EvalProtocol`, each cell's episodes parallel worlds of one rollout
(``evaluation/rollout.py``). Robustness per mode: mean and worst success over the damping set.

Anything that maps observations to controls evaluates here with one set of metric names: a
:class:`~dragmesh2_jax.policies.controller.Controller` (a trained run's, the tracking baselines, brax's policies,
the parallel-jaw primitive).
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from dragmesh2_jax.baselines.tracking import tracking_controller
from dragmesh2_jax.evaluation.protocol import EvalProtocol
from dragmesh2_jax.evaluation.rollout import cells, rollout
from dragmesh2_jax.io import atomic_write_figure
from dragmesh2_jax.policies.controller import Controller
from dragmesh2_jax.progress import LogLines
from dragmesh2_jax.task.env import PullTask
from dragmesh2_jax.task.protocol import Env


def robustness(records: list[dict], modes: list[str]) -> dict:
    """Paper eq. robust: mean and worst success over the damping set, per mode (plus mean active clip099)."""
    out = {}
    for m in modes:
        rs = [r for r in records if r["mode"] == m]
        s = [r["success_rate"] for r in rs]
        out[m] = {"mean_success": float(np.mean(s)), "worst_success": float(np.min(s)),
                  "clip099_active": float(np.mean([r["clip099_active"] for r in rs]))}
    return out


def evaluate(task: Env, controller: Controller, protocol: EvalProtocol, progress: bool = False) -> dict:
    """Every (damping, mode) cell of ``protocol`` on ``task`` (the protocol's task: ``protocol.task(...)``, or a
    controller's own task with the protocol's starts); ``progress``: a line to standard error while the rollout
    compiles and one per mode with the time left."""
    if task.config.reset_noise != protocol.starts:
        raise ValueError("evaluate needs the protocol's starts (build the task with protocol.task(task))")
    dampings = list(protocol.dampings)
    records = []
    lines = LogLines("evaluate", len(protocol.modes), enabled=progress, terminal=True)
    if progress:
        print(f"evaluate: compiling the rollout ({len(dampings)} dampings x {protocol.episodes} episodes per mode)",
              file=sys.stderr, flush=True)
    for i, m in enumerate(protocol.modes):
        key = None if controller.key is None else (controller.key, m)
        result = rollout(task, controller.make_policy(m == "det"), controller.params, dampings, protocol.episodes,
                         protocol.seed, controller.controls, key=key)
        records += [{**r, "mode": m} for r in cells(result, dampings, protocol.episodes)]
        lines(i + 1, f"mode {m} ({i + 1}/{len(protocol.modes)})")
    return {"cells": records, "robustness": robustness(records, list(protocol.modes)),
            "object_id": task.object_id, "method": controller.name, "backend": task.engine,
            "protocol": dataclasses.asdict(protocol)}


def track(task: PullTask, dampings: list[float], episodes: int = 1, seed: int = 0) -> list[dict]:
    """The cells of the tracking baseline on ``task`` (its own starts: exact unless its config perturbs them) at
    each damping multiplier."""
    c = tracking_controller(task)
    return cells(rollout(task, c.make_policy(True), c.params, dampings, episodes, seed, c.controls, key=c.key),
                 dampings, episodes)


#: The expert's paces an envelope replays (1: the trajectory's own; 0.5: twice as slow) and its dampings (x8: the
#: recipe's training range's end; x16 beyond it).
ENVELOPE_PACES = (0.33, 0.5, 1.0, 2.0, 4.0)
ENVELOPE_DAMPINGS = (1.0, 2.0, 4.0, 8.0, 16.0)


def envelope(task: PullTask, paces=ENVELOPE_PACES, dampings=ENVELOPE_DAMPINGS) -> list[dict]:
    """The object's physical envelope: the expert drag replayed open-loop at each pace and damping from the
    task's start, within the task's episode length. Per cell: whether it opened, the episode's steps, final
    progress, detachment and the peak wrist load (N). A cell the expert opens at some pace is reachable through
    contact; one it opens at no pace may still be for a closed-loop policy (the part can lag behind a
    time-indexed path). With the part's peak speed (joint units per second)."""
    rows = []
    for pace in paces:
        c = tracking_controller(task, pace)
        r = rollout(task, c.make_policy(True), c.params, list(dampings), controls=c.controls,
                    steps=task.config.episode_length, key=c.key)
        for i, d in enumerate(dampings):
            live = r["live"][:, i]
            rows.append({"pace": float(pace), "damping": float(d), "opened": bool(r["acc"]["success"][i] > 0),
                         "steps": int(live.sum()), "progress": float(r["acc"]["progress"][i]),
                         "detached": bool(r["acc"]["detach"][i] > 0),
                         "wrist_load_peak_n": float(r["wrist_load"][live, i].max(initial=0.0)),
                         "part_speed_peak": float(r["acc"]["part_speed_peak"][i])})
    return rows


def envelope_table(rows: list[dict]) -> str:
    """Paces x dampings: ``opens (steps, peak wrist load)`` or how it failed (detached, or out of time at a
    progress)."""
    dampings = sorted({r["damping"] for r in rows})
    lines = ["| pace | " + " | ".join(f"x{d:g}" for d in dampings) + " |", "|---" * (len(dampings) + 1) + "|"]
    for pace in dict.fromkeys(r["pace"] for r in rows):
        cells_ = []
        for r in (r for r in rows if r["pace"] == pace):
            how = "opens" if r["opened"] else ("detaches" if r["detached"] else f"times out at {r['progress']:.2f}")
            cells_.append(f"{how} ({r['steps']} steps, {r['wrist_load_peak_n']:.0f} N)")
        lines.append(f"| {pace:g}x | " + " | ".join(cells_) + " |")
    return "\n".join(lines)


def envelope_figure(rows: list[dict], path: str | Path, title: str = "") -> Path:
    """The envelope as a grid (paces down, dampings across): green where the expert opens the part, red where it
    detaches, grey where it runs out of time; each cell with its steps and peak wrist load."""
    dampings = sorted({r["damping"] for r in rows})
    paces = list(dict.fromkeys(r["pace"] for r in rows))
    fig = Figure(figsize=(1.3 + 1.25 * len(dampings), 0.9 + 0.55 * len(paces)))
    ax = fig.subplots()
    colours = {"opens": "#4caf50", "detaches": "#e53935", "times out": "#9e9e9e"}
    for i, pace in enumerate(paces):
        for j, d in enumerate(dampings):
            r = next(r for r in rows if r["pace"] == pace and r["damping"] == d)
            how = "opens" if r["opened"] else "detaches" if r["detached"] else "times out"
            ax.add_patch(Rectangle((j, i), 0.96, 0.92, color=colours[how]))
            ax.text(j + 0.48, i + 0.46, f"{r['steps']} st\n{r['wrist_load_peak_n']:.0f} N", ha="center", va="center",
                    fontsize=7, color="white")
    ax.set_xlim(0, len(dampings))
    ax.set_ylim(len(paces), 0)
    ax.set_xticks([j + 0.48 for j in range(len(dampings))], [f"x{d:g}" for d in dampings])
    ax.set_yticks([i + 0.46 for i in range(len(paces))], [f"{p:g}x" for p in paces])
    ax.set_xlabel("damping multiplier")
    ax.set_ylabel("pace of the expert drag")
    ax.set_title(title or "envelope: green opens, red detaches, grey out of time", fontsize=8)
    ax.tick_params(length=0)
    for spine in ax.spines.values():
        spine.set_visible(False)
    fig.tight_layout()
    return atomic_write_figure(path, fig, dpi=120)


#: The physical figures of a cell (``rollout.cells``) as table columns: key, header, format.
PHYSICAL = (
    ("wrist_load_peak_n", "wrist load p95 [N]", "{:.0f}"),
    ("palm_speed_peak_m_s", "palm speed p95 [m/s]", "{:.2f}"),
    ("palm_speed_settled_peak_m_s", "settled [m/s]", "{:.2f}"),
    ("part_speed_peak", "part speed p95 [/s]", "{:.2f}"),
    ("penetration_max_mm", "penetration max [mm]", "{:.1f}"),
    ("penetration_settled_p95_mm", "settled p95 [mm]", "{:.1f}"),
    ("action_smoothness", "mean abs action change", "{:.3f}"),
)


def markdown_table(result: dict) -> str:
    """The cells (success with its interval, how far and how long, saturation, and the physical figures: the wrist
    load, the palm's and the part's pace, penetration and smoothness) and the robustness per mode."""
    lines = ["| damping | mode | success [95% CI] | progress | return | steps | clip099 | clip099 active | "
             "policy's own clip099 active | detach | action L2 | " + " | ".join(h for _, h, _ in PHYSICAL) + " |",
             "|---" * (11 + len(PHYSICAL)) + "|"]
    for r in result["cells"]:
        lo, hi = r["success_ci95"]
        own = r.get("clip099_policy_active")  # an evaluation written before it was counted has none
        lines.append(f"| x{r['damping']:g} | {r['mode']} | {r['success_rate']:.2f} [{lo:.2f}, {hi:.2f}] | "
                     f"{r['progress_mean']:.2f} | {r['return_mean']:.1f} | {r['steps_mean']:.1f} | "
                     f"{r['clip099']:.3f} | {r['clip099_active']:.3f} | {'-' if own is None else f'{own:.3f}'} | "
                     f"{r['detach_rate']:.2f} | "
                     f"{r['action_l2_mean']:.2f} | " + " | ".join(f.format(r[k]) for k, _, f in PHYSICAL) + " |")
    lines += ["", "| mode | mean success | worst success | clip099 active |", "|---|---|---|---|"]
    for m, v in result["robustness"].items():
        lines.append(f"| {m} | {v['mean_success']:.2f} | {v['worst_success']:.2f} | {v['clip099_active']:.3f} |")
    return "\n".join(lines)
