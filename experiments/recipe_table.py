"""The recipe's table (RESULTS.md §3): per object, the grasp its expert keeps and, over seeds, det success at each
damping (mean, the lowest seed's beside it), the x1 wrist load p95, the palm speed p95 at x1 and x8, the deepest
penetration and the policy's own saturation at x1; the previous recipe on the same object beside it.

    python experiments/recipe_table.py results/recipe.json   (a JSON list of rows: {"object", "grasp", "runs": GLOB,
        "before": GLOB}, each GLOB matching one evaluation file per seed)"""

from __future__ import annotations

import argparse
import glob
import json
import sys
from pathlib import Path

import numpy as np


def figures(files: list[Path]) -> dict:
    evals = [json.loads(f.read_text()) for f in files]
    cell = lambda e, d: next((c for c in e["cells"] if c["damping"] == d and c["mode"] == "det"), None)  # noqa: E731
    out = {"seeds": len(evals)}
    for d in (1.0, 2.0, 4.0, 8.0, 16.0):
        s = [c["success_rate"] for e in evals if (c := cell(e, d))]
        out[f"x{d:g}"] = f"{np.mean(s):.2f}" + (f" ({min(s):.2f})" if min(s) < np.mean(s) else "") if s else "-"
    one, eight = [cell(e, 1.0) for e in evals], [cell(e, 8.0) for e in evals]
    mean = lambda cs, k: float(np.mean([c[k] for c in cs]))  # noqa: E731
    out["load"] = f"{mean(one, 'wrist_load_peak_n'):.0f}"
    out["palm"] = f"{mean(one, 'palm_speed_peak_m_s'):.2f} -> {mean(eight, 'palm_speed_peak_m_s'):.2f}"
    out["penetration"] = f"{max(c['penetration_max_mm'] for e in evals for c in e['cells']):.1f}"
    has_own = all("clip099_policy_active" in c for c in one)  # evaluations before 2026-12-06 do not count it
    out["own"] = f"{mean(one, 'clip099_policy_active'):.2f}" if has_own else "-"
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rows")
    a = ap.parse_args(argv)
    print("| object (grasp kept) | x1 | x2 | x4 | x8 | x16 | x1 load p95 [N] | palm p95 x1 -> x8 [m/s] | penetration "
          "[mm] | own saturation x1 |")
    print("|---" * 10 + "|")
    for row in json.loads(Path(a.rows).read_text()):
        for label, pattern in ((f"{row['object']} ({row['grasp']})", row["runs"]),
                               ("  previous recipe", row["before"])):
            files = [Path(f) for f in sorted(glob.glob(pattern))]
            if not files:
                print(f"error: no evaluation files match {pattern}", file=sys.stderr)
                return 2
            f = figures(files)
            print(f"| {label} | " + " | ".join(f[k] for k in ("x1", "x2", "x4", "x8", "x16", "load", "palm",
                                                              "penetration", "own")) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
