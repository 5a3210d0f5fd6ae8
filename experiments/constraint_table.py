"""Whether a constraint's budget is met by the end of training (issue 33): per run, the mean of its epoch cost over
the last epochs against its budget, its multiplier at the end and how much it still rose over those epochs (a
multiplier that has stopped rising with the cost at its budget is dual ascent at rest; one still rising is a
penalty the policy has not met), and on which actions the cost was counted: the sampled ones (``sampled``) or the
worlds that act on the policy's mean (``mean``, ``PPOConfig.mean_share``), the policy the evaluation reads.

    python experiments/constraint_table.py OUT --row "LABEL=GLOB" [--row ...] [--last 10]

Each GLOB, under OUT, matches run folders (their ``run.json`` and ``log.csv``: a run's own folder or the copies
results/plausible keeps); every constraint of each run is a line."""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

import numpy as np

from dragmesh2_jax.task.config import Constraint
from dragmesh2_jax.task.rewards import cost_metric


def convergence(folder: Path, last: int) -> list[dict]:
    """Per constraint of the run in ``folder``: its measure, budget, mean cost over the ``last`` epochs, final
    multiplier and its rise over them."""
    record = json.loads((folder / "run.json").read_text())
    constraints = record["task"]["reward"]["constraints"]
    counted = "mean" if record.get("ppo", {}).get("mean_share", 0) else "sampled"
    if not (folder / "log.csv").exists():  # a run that has not finished its first epoch
        return []
    with open(folder / "log.csv", newline="") as f:
        rows = list(csv.DictReader(f))[-last:]
    out = []
    for c in constraints:
        cost = np.asarray([float(r[cost_metric(Constraint(**c))]) for r in rows])
        lam = np.asarray([float(r[f"lambda_{c['measure']}"]) for r in rows])
        out.append({"measure": c["measure"], "cost": c["cost"], "counted": counted, "budget": c["budget"],
                    "mean_cost": float(cost.mean()), "lambda": float(lam[-1]), "lambda_rise": float(lam[-1] - lam[0])})
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--row", action="append", required=True, help="LABEL=GLOB")
    ap.add_argument("--last", type=int, default=10)
    a = ap.parse_args(argv)
    print(f"| method | seed run | constraint (cost; counted on) | budget | mean cost, last {a.last} epochs | met | "
          f"multiplier (rise over them) |\n|---|---|---|---|---|---|---|")
    for row in a.row:
        label, pattern = row.split("=", 1)
        folders = sorted(p.parent for p in a.out.glob(f"{pattern}/run.json"))
        if not folders:
            raise SystemExit(f"error: no run folder matches {pattern!r} under {a.out}")
        for folder in folders:
            for c in convergence(folder, a.last):
                print(f"| {label} | {folder.name} | {c['measure']} ({c['cost']}; {c['counted']}) | {c['budget']:g} | "
                      f"{c['mean_cost']:.4f} | {'yes' if c['mean_cost'] <= c['budget'] else 'no'} | "
                      f"{c['lambda']:.1f} ({c['lambda_rise']:+.1f}) |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
