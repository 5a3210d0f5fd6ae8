"""Where a load-bounded policy spends its budget (issue 33): per damping, the share of control steps whose wrist
load is past the object's expert unit (``relative_load`` > 1: the expert drag's own peak from its exact grasp at the
world's damping) and the mean excess past it, max(0, relative_load - 1), over the evaluation's perturbed starts
(deterministic), beside the expert drag replayed at its own pace from the same starts: what the constraint asks of
the policy against what the expert itself does.

    python experiments/load_budget.py --runs RUN [RUN ...] [--labels A B ...] [--episodes 16] [--damping 1,2,4,8]
        [--out budget.json]

Each RUN is a run folder of a method whose constraint reads ``relative_load`` (its checkpoint by its method's rule);
every run must be on the same object. Prints a markdown table and writes the numbers as JSON."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from dragmesh2_jax.baselines.tracking import tracking_controller
from dragmesh2_jax.evaluation.protocol import EvalProtocol
from dragmesh2_jax.evaluation.rollout import rollout
from dragmesh2_jax.io import atomic_write_json
from dragmesh2_jax.runs.commands import load_run
from dragmesh2_jax.task.expert import load_unit


def spend(task, controller, dampings: list[float], episodes: int) -> list[dict]:
    """Per damping: the share of live steps past the unit, the mean excess past it and the first tenth of the
    episode's share of those steps (a start transient or a steady pull)."""
    r = rollout(task, controller.make_policy(True), controller.params, dampings, episodes, 0, controller.controls,
                steps=task.config.episode_length, key=controller.key)
    scales = np.repeat(dampings, episodes)
    rel = r["wrist_load"] / np.asarray(load_unit(task.params.expert_load, scales))[None, :]
    early = np.arange(len(rel))[:, None] < task.config.episode_length // 10
    rows = []
    for d in dampings:
        cols = scales == d
        live, x = r["live"][:, cols], rel[:, cols]
        over = (x > 1.0) & live
        rows.append({"damping": d, "unit_n": float(load_unit(task.params.expert_load, np.float32(d))),
                     "rate": float(over.sum() / live.sum()),
                     "excess": float(np.where(live, np.maximum(x - 1.0, 0.0), 0.0).sum() / live.sum()),
                     "early_share": float((over & early).sum() / max(over.sum(), 1)),
                     "success": float(r["acc"]["success"][cols].mean())})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", nargs="+", required=True)
    ap.add_argument("--labels", nargs="+")
    ap.add_argument("--episodes", type=int, default=16)
    ap.add_argument("--damping", default="1,2,4,8")
    ap.add_argument("--out", default="budget.json")
    a = ap.parse_args(argv)
    dampings = [float(d) for d in a.damping.split(",")]
    labels = a.labels or [Path(r).name for r in a.runs]
    protocol = EvalProtocol(dampings=tuple(dampings), modes=("det",), episodes=a.episodes)
    table, task = {}, None
    for label, folder in zip(labels, a.runs, strict=True):
        program, ts, _, _ = load_run(folder)
        task = protocol.task(program.task)
        table[label] = spend(task, program.controller(ts), dampings, a.episodes)
    table["expert (its own pace)"] = spend(task, tracking_controller(task), dampings, a.episodes)
    print(f"{task.object_id}: share of steps past the expert's peak / mean excess past it (det, {a.episodes} "
          "perturbed starts per damping)\n")
    print("| | " + " | ".join(f"x{d:g} ({r['unit_n']:.0f} N)" for d, r in zip(dampings, next(iter(table.values())),
                                                                             strict=True)) + " |")
    print("|---" * (len(dampings) + 1) + "|")
    for label, rows in table.items():
        print(f"| {label} | " + " | ".join(f"{r['rate']:.2f} / {r['excess']:.3f}" for r in rows) + " |")
    atomic_write_json(a.out, {"object_id": task.object_id, "episodes": a.episodes, "rows": table})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
