"""A method's adoption table (issue "Hold on and follow"; results/screen/RULE.md, fifteenth step): per object, over
its seeds' runs, the policy against the expert in use from the same starts, and each clause of the rule met or missed.

Each run folder holds two evaluations under the default perturbed starts, det, 50 episodes per cell:
``dragmesh2 evaluate --checkpoint RUN --episodes 50 --mode det`` (the policy, x1-x16) and ``dragmesh2 evaluate
--checkpoint RUN --method tracking --damping 1,8 --episodes 50 --mode det`` (its expert: the same drag, grasp and
contacts replayed as PD targets from the same starts; or ``--method prior``, the residual method's prior alone,
which a run's ``prior`` evaluation stands for where it has one).

    python experiments/adoption_table.py [--unseated] RUN [RUN ...]   (runs named OBJECT_METHOD_sSEED, as
        relative_load.sh names them; a run without both evaluations is listed as missing; --unseated: evaluations
        from starts kept clear around the grasp as written, those made before starts were seated)

The clauses, per object (means over seeds unless said):
  success  det success >= 0.95 at x1, x2, x4 and x8 with every seed
  load     x1 wrist load p95 <= 1.2x the expert's from the same starts
  palm     settled palm p95 at x4 and x8 <= 1.1x the x1 figure, and at every damping <= 2x the expert's at x1
  pen      penetration p95 (over episodes, of each one's deepest hand-object contact: the cells' deepest-contact
           figure) <= 2 mm for the policy at x1-x8 and for the expert at x1; the recount from the sixth control step
           (settled) and the deepest of any episode beside it
  own      the policy's own saturation at x1 <= 0.3
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import re
import sys
from pathlib import Path

import numpy as np

from dragmesh2_jax.evaluation.protocol import EvalProtocol
from dragmesh2_jax.runs.overrides import RECIPE_DAMPINGS

POLICY = EvalProtocol(dampings=RECIPE_DAMPINGS, modes=("det",), episodes=50)
EXPERT = EvalProtocol(dampings=(1.0, 8.0), modes=("det",), episodes=50)
#: The expert in use, by its evaluation's name: the prior alone where a run has it, else the drag replayed.
EXPERTS = ("prior", "tracking")
SUCCESS, LOAD, PALM_RISE, PALM_EXPERT, PENETRATION_MM, OWN = 0.95, 1.2, 1.1, 2.0, 2.0, 0.3


def cells(path: Path) -> dict[float, dict] | None:
    if not path.is_file():
        return None
    return {c["damping"]: c for c in json.loads(path.read_text())["cells"] if c["mode"] == "det"}


def unseated(protocol: EvalProtocol) -> EvalProtocol:
    """``protocol`` from starts kept clear around the grasp as written (its files' names from before seating)."""
    return dataclasses.replace(protocol, starts=dataclasses.replace(protocol.starts, seat=False))


def expert_cells(run: Path, protocol: EvalProtocol) -> dict[float, dict] | None:
    found = (cells(run / "evaluations" / f"{name}__{protocol.name}.json") for name in EXPERTS)
    return next((c for c in found if c is not None), None)


def row(obj: str, runs: list[Path], policy: EvalProtocol = POLICY, expert: EvalProtocol = EXPERT) -> list[str]:
    pol = [cells(r / "evaluations" / f"final__{policy.name}.json") for r in runs]
    exp = [expert_cells(r, expert) for r in runs]
    if any(c is None for c in pol + exp):
        return [obj, f"missing evaluations ({sum(c is None for c in pol + exp)} of {2 * len(runs)})"]
    mean = lambda cs, d, k: float(np.mean([c[d][k] for c in cs]))  # noqa: E731
    success = {d: [c[d]["success_rate"] for c in pol] for d in RECIPE_DAMPINGS}
    load, expert_load = mean(pol, 1.0, "wrist_load_peak_n"), mean(exp, 1.0, "wrist_load_peak_n")
    palm = {d: mean(pol, d, "palm_speed_settled_peak_m_s") for d in RECIPE_DAMPINGS}
    whole = {d: mean(pol, d, "palm_speed_peak_m_s") for d in (1.0, 4.0, 8.0)}
    expert_palm = mean(exp, 1.0, "palm_speed_settled_peak_m_s")
    held = [d for d in RECIPE_DAMPINGS if d <= 8.0]
    pen = max(mean(pol, d, "penetration_p95_mm") for d in held)
    settled = max(mean(pol, d, "penetration_settled_p95_mm") for d in held)
    deepest = max(mean(pol, d, "penetration_max_mm") for d in held)
    expert_pen = mean(exp, 1.0, "penetration_p95_mm")
    own = mean(pol, 1.0, "clip099_policy_active")
    ok = {"success": all(min(success[d]) >= SUCCESS for d in (1.0, 2.0, 4.0, 8.0)),
          "load": load <= LOAD * expert_load,
          "palm": max(palm[4.0], palm[8.0]) <= PALM_RISE * palm[1.0]
          and max(palm[d] for d in RECIPE_DAMPINGS if d <= 8.0) <= PALM_EXPERT * expert_palm,
          "pen": pen <= PENETRATION_MM and expert_pen <= PENETRATION_MM, "own": own <= OWN}
    succ = " / ".join(f"{np.mean(success[d]):.2f}" + (f" ({min(success[d]):.2f})" if min(success[d]) < np.mean(
        success[d]) else "") for d in RECIPE_DAMPINGS)
    return [obj, str(len(runs)), succ, f"{load:.0f} ({expert_load:.0f}; {load / expert_load:.2f}x)",
            f"{palm[1.0]:.2f} / {palm[4.0]:.2f} / {palm[8.0]:.2f} ({expert_palm:.2f}; whole "
            f"{whole[1.0]:.2f} / {whole[4.0]:.2f} / {whole[8.0]:.2f})",
            f"{pen:.1f} ({expert_pen:.1f}; settled {settled:.1f}, deepest {deepest:.1f})", f"{own:.2f}",
            ", ".join(k for k, v in ok.items() if not v) or "all met"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--unseated", action="store_true", help="evaluations made before starts were seated")
    a = ap.parse_args(argv)
    by_object: dict[tuple[str, str], list[Path]] = {}  # a method's seeds on an object
    for run in sorted(a.runs):
        m = re.fullmatch(r"((.+?)_[a-z_]+)_s\d+", run.name)
        if not m:
            print(f"error: {run}: not named OBJECT_METHOD_sSEED", file=sys.stderr)
            return 2
        by_object.setdefault((m.group(2), m.group(1)), []).append(run)
    protocols = (unseated(POLICY), unseated(EXPERT)) if a.unseated else (POLICY, EXPERT)
    print("| object | seeds | det success x1 / x2 / x4 / x8 / x16 (lowest seed) | x1 load p95 [N] (expert; ratio) | "
          "settled palm p95 x1 / x4 / x8 [m/s] (expert x1; whole) | penetration p95 x1-x8 [mm] (expert x1; "
          "settled, deepest) | own sat. x1 | clauses missed |")
    print("|---|---|---|---|---|---|---|---|")
    for (obj, _), runs in by_object.items():
        print("| " + " | ".join(row(obj, runs, *protocols)) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
