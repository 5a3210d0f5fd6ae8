"""How a policy paces to the load (issue 33): its wrist load |F_wrist| and the part's speed against time at each
damping, from the exact expert grasp (deterministic), beside the expert replayed at its own pace.

    python experiments/pace_figure.py --runs RUN [RUN ...] [--labels A B ...] [--damping 1,8] --out pace.png

Each RUN is a run folder (its checkpoint by its method's rule); every run must be on the same object. A JSON of the
plotted series is written beside the figure (``pace.json``)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from dragmesh2_jax.baselines.tracking import tracking_controller
from dragmesh2_jax.evaluation.protocol import EvalProtocol
from dragmesh2_jax.evaluation.rollout import frames, rollout
from dragmesh2_jax.io import atomic_write_figure, atomic_write_json
from dragmesh2_jax.runs.commands import load_run


def series(task, controller, dampings: list[float]) -> list[dict]:
    """Per damping: wrist load (N) and part speed (joint units per second) at each step of the first episode."""
    r = rollout(task, controller.make_policy(True), controller.params, dampings, 1, 0, controller.controls,
                steps=task.config.episode_length, key=controller.key)
    out = []
    for row in frames(r, dampings):
        speed = np.diff(row["obj_q"], prepend=row["obj_q"][:1]) / task.config.control_dt
        out.append({"damping": row["damping"], "load_n": row["wrist_load"].tolist(), "part_speed": speed.tolist(),
                    "success": row["success"], "detach": row["detach"], "steps": row["steps"]})
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", nargs="+", required=True)
    ap.add_argument("--labels", nargs="+")
    ap.add_argument("--damping", default="1,8")
    ap.add_argument("--out", default="pace.png")
    a = ap.parse_args(argv)
    dampings = [float(d) for d in a.damping.split(",")]
    labels = a.labels or [Path(r).name for r in a.runs]
    curves, task = {}, None
    for label, folder in zip(labels, a.runs, strict=True):
        program, ts, _, _ = load_run(folder)
        task = EvalProtocol(starts=None).task(program.task)  # the exact expert grasp
        curves[label] = series(task, program.controller(ts), dampings)
    curves["expert (its own pace)"] = series(task, tracking_controller(task), dampings)
    fig = Figure(figsize=(5 * len(dampings), 6))
    axes = fig.subplots(2, len(dampings), squeeze=False, sharex=True)
    dt = task.config.control_dt
    for label, rows in curves.items():
        for j, row in enumerate(rows):
            t = np.arange(row["steps"]) * dt
            end = "opened" if row["success"] else "detached" if row["detach"] else "not opened in time"
            axes[0, j].plot(t, row["load_n"][:row["steps"]], label=f"{label} ({end}, {row['steps']} steps)")
            axes[1, j].plot(t, row["part_speed"][:row["steps"]], label=label)
    unit = "rad/s" if task.scene.ids.target_is_revolute else "m/s"
    for j, d in enumerate(dampings):
        axes[0, j].set_title(f"{task.scene.obj.object_id}, damping x{d:g}")
        axes[0, j].set_ylabel("wrist load |F| [N]")
        axes[1, j].set_ylabel(f"part speed [{unit}]")
        axes[1, j].set_xlabel("time [s]")
        axes[0, j].legend(fontsize=7)
    fig.tight_layout()
    out = Path(a.out)
    atomic_write_figure(out, fig, dpi=120)
    atomic_write_json(out.with_suffix(".json"), {"object": task.scene.obj.object_id, "dampings": dampings,
                                                 "runs": dict(zip(labels, a.runs, strict=True)), "curves": curves})
    print(json.dumps({k: [(r["damping"], r["steps"], r["success"], round(max(r["load_n"][:r["steps"]]), 1))
                          for r in v] for k, v in curves.items()}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
