"""The table of experiments/plausible_hold.sh: per method and damping, success and the physical figures (mean ± SE
over seeds, every seed's value), from the evaluation files the runs keep, with the expert at its own pace beside them.

    python experiments/plausible_table.py OUT [--mode det]   (OUT: the script's output folder or results/plausible)
    python experiments/plausible_table.py OUT --object DIR --row "LABEL=GLOB" [--row ...] [--experts planned,seated]
        (only these rows: each GLOB, under OUT, matches one evaluation file per seed on the object in DIR; the expert
        rows: the paper's planned grasp, and the seated grasp that holds, the recipe's expert since 2026-12-06)"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from dragmesh2_jax.baselines.tracking import tracking_controller
from dragmesh2_jax.evaluation.evaluate import evaluate
from dragmesh2_jax.evaluation.protocol import EvalProtocol
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.runs.overrides import RECIPE_DAMPINGS
from dragmesh2_jax.runs.spec import method_defaults

#: The expert grasps a table can list beside the rows: each's TaskConfig fields (the paper's; the recipe's).
EXPERTS = {"planned": {}, "seated": {k: getattr(method_defaults("recommended").task, k)
                                     for k in ("expert_grasp", "expert_placement")}}

COLUMNS = (("success_rate", "success", "{:.2f}"), ("wrist_load_peak_n", "wrist load p95 [N]", "{:.0f}"),
           ("palm_speed_peak_m_s", "palm p95 [m/s]", "{:.2f}"), ("steps_mean", "steps", "{:.0f}"),
           ("clip099_active", "clip099 active", "{:.2f}"), ("penetration_max_mm", "penetration [mm]", "{:.1f}"),
           ("action_smoothness", "action change", "{:.3f}"))


def cell(values: list[float], fmt: str) -> str:
    v = np.asarray(values, float)
    se = v.std(ddof=1) / np.sqrt(len(v)) if len(v) > 1 else 0.0
    return f"{fmt.format(v.mean())} ± {fmt.format(se)} ({', '.join(fmt.format(x) for x in v)})"


def evaluations(folder: Path, checkpoint: str = "*", modes: str = "det-stoch") -> list[Path]:
    """The run's evaluation files of ``checkpoint`` at x1-x16, 50 episodes, sorted: in the run's evaluations, or
    beside its run.json (as results/plausible keeps them)."""
    pattern = f"{checkpoint}__x1-2-4-8-16_{modes}_n50_*.json"
    return sorted([*folder.glob(f"evaluations/{pattern}"), *folder.glob(pattern)])


def latest(folder: Path, checkpoint: str = "*", modes: str = "det-stoch") -> dict:
    """The run's last evaluation of ``checkpoint`` (by default its last checkpoint: its final one, which reproduce
    names by its epoch)."""
    (path,) = evaluations(folder, checkpoint, modes)[-1:]
    return json.loads(path.read_text())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--mode", default="det")
    ap.add_argument("--row", action="append", default=[], metavar="LABEL=GLOB")
    ap.add_argument("--object", help="the rows' object folder (with --row)")
    ap.add_argument("--experts", default="planned", help="the expert rows (comma-separated: planned, seated)")
    a = ap.parse_args(argv)
    out = Path(a.out)
    if a.row:
        rows = dict(r.split("=", 1) for r in a.row)
        print(table({label: [json.loads(f.read_text()) for f in sorted(out.glob(g))] for label, g in rows.items()},
                    a.mode, a.object, a.experts.split(",")))
        return 0
    runs = lambda *patterns: sorted(f for pattern in patterns for f in out.glob(pattern))  # noqa: E731
    # the recipe at the paper's budget: its runs' epoch-150 checkpoints (evaluated det only: `evaluate --checkpoint
    # RUN/checkpoints/epoch_0150 --mode det`, the other cells as above)
    hold150 = [f for f in runs("door/runs/*/hold_blind_s*", "hold_blind_s*") if evaluations(f, "epoch_0150", "det")]
    rows = {"pica (300 epochs)": runs("door_paper/runs/*/pica_s*", "pica_s*"),
            "state_only (300 epochs)": runs("door_paper/runs/*/state_only_s*", "state_only_s*"),
            "hold_blind (300 epochs)": runs("door/runs/*/hold_blind_s*", "hold_blind_s*"),
            **{f"hold_blind 150 + {r} 150": runs(f"{r}/s*", f"{r}_s*")
               for r in ("plausible", "plausible_cap100", "plausible_load")}}
    cells = {name: [latest(f) for f in folders] for name, folders in rows.items()}
    if hold150 and a.mode == "det":
        cells = {"hold_blind (150 epochs)": [latest(f, "epoch_0150", "det") for f in hold150], **cells}
    print(table(cells, a.mode, json.loads((rows["hold_blind (300 epochs)"][0] / "run.json").read_text())["object"]))
    return 0


def table(cells: dict[str, list[dict]], mode: str, obj: str, experts: list[str] = ("planned",)) -> str:
    """Per row (its seeds' evaluations) and damping x1-x16, the cells of ``mode``; each of ``experts`` (EXPERTS) at
    its own pace on the rows' object (its folder ``obj``) from the same 50 starts below them."""
    lines = ["| method | damping | " + " | ".join(h for _, h, _ in COLUMNS) + " |",
             "|---|---|" + "---|" * len(COLUMNS)]
    for name, evals in cells.items():
        if not evals:  # a variant not run into OUT
            continue
        for d in RECIPE_DAMPINGS:
            cs = [next(c for c in e["cells"] if c["damping"] == d and c["mode"] == mode) for e in evals]
            figures = " | ".join(cell([c[k] for c in cs], f) for k, _, f in COLUMNS)
            lines.append(f"| {name} | x{d:g} | {figures} |")
    protocol = EvalProtocol(dampings=RECIPE_DAMPINGS, modes=("det",), episodes=50)
    for name in experts:
        task = load_task(obj, None, backend="mujoco", **EXPERTS[name])
        label = "expert (its own pace)" if name == "planned" else f"{name} expert (its own pace)"
        for c in evaluate(protocol.task(task), tracking_controller(task), protocol)["cells"]:
            lines.append(f"| {label} | x{c['damping']:g} | " + " | ".join(f.format(c[k]) for k, _, f in COLUMNS) + " |")
    return "\n".join(lines)


if __name__ == "__main__":
    raise SystemExit(main())
