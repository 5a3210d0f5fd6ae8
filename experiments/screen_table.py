"""The lever screen's tables (experiments/hold_screen.sh): per run, det success at x1-x8 and the physical figures; with
``--seeds``, per lever and door over its seeds (runs ``LEVER_OBJECT`` and ``LEVER_OBJECT_sS``): mean, standard error
and every seed's value.

    python experiments/screen_table.py runs/screen > results/screen/table.md
    python experiments/screen_table.py runs/screen --seeds > results/screen/seeds.md"""

from __future__ import annotations

import json
import re
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

DAMPINGS = (1.0, 2.0, 4.0, 8.0)
#: The palm's figure once the start has settled (evaluations made before it have none: "-").
SETTLED = "palm_speed_settled_peak_m_s"


def _cells(f: Path) -> dict[float, dict]:
    return {cell["damping"]: cell for cell in json.loads(f.read_text())["cells"]}


def runs(folder: str) -> None:
    print("| run | " + " | ".join(f"x{d:g}" for d in DAMPINGS) + " | x1 load p95 [N] | x8 load | palm x1 -> x8 [m/s] "
          "| settled | penetration max [mm] | clip099 active | policy's own |")
    print("|---" * (8 + len(DAMPINGS)) + "|")
    for f in sorted(Path(folder).glob("*.eval.json")):
        c = _cells(f)
        settled = "-" if SETTLED not in c[1.0] else f"{c[1.0][SETTLED]:.2f} -> {c[8.0][SETTLED]:.2f}"
        print(f"| {f.name.removesuffix('.eval.json')} | " + " | ".join(f"{c[d]['success_rate']:.2f}" for d in DAMPINGS)
              + f" | {c[1.0]['wrist_load_peak_n']:.0f} | {c[8.0]['wrist_load_peak_n']:.0f} | "
              f"{c[1.0]['palm_speed_peak_m_s']:.2f} -> {c[8.0]['palm_speed_peak_m_s']:.2f} | {settled} | "
              f"{max(cell['penetration_max_mm'] for cell in c.values()):.1f} | {c[1.0]['clip099_active']:.2f} | "
              f"{c[1.0]['clip099_policy_active']:.2f} |")


def _stat(values: list[float], fmt: str) -> str:
    """mean ± standard error (each seed's value)."""
    se = np.std(values, ddof=1) / np.sqrt(len(values)) if len(values) > 1 else 0.0
    return f"{np.mean(values):{fmt}} ± {se:{fmt}} ({', '.join(f'{v:{fmt}}' for v in values)})"


def seeds(folder: str) -> None:
    groups: dict[str, list[dict]] = defaultdict(list)
    for f in sorted(Path(folder).glob("*.eval.json")):
        groups[re.sub(r"_s\d+$", "", f.name.removesuffix(".eval.json"))].append(_cells(f))
    print("| run | seeds | " + " | ".join(f"x{d:g}" for d in DAMPINGS) + " | x1 load p95 [N] | palm x1 [m/s] | palm x8 "
          "| penetration max [mm] | policy's own saturation x1 |")
    print("|---" * (7 + len(DAMPINGS)) + "|")
    for name, cells in groups.items():
        row = [_stat([c[d]["success_rate"] for c in cells], ".2f") for d in DAMPINGS]
        row += [_stat([c[1.0]["wrist_load_peak_n"] for c in cells], ".0f"),
                _stat([c[1.0]["palm_speed_peak_m_s"] for c in cells], ".2f"),
                _stat([c[8.0]["palm_speed_peak_m_s"] for c in cells], ".2f"),
                _stat([max(x["penetration_max_mm"] for x in c.values()) for c in cells], ".1f"),
                _stat([c[1.0]["clip099_policy_active"] for c in cells], ".2f")]
        print(f"| {name} | {len(cells)} | " + " | ".join(row) + " |")


if __name__ == "__main__":
    (seeds if "--seeds" in sys.argv[2:] else runs)(sys.argv[1])
