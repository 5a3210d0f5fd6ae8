"""The lever screen's table (experiments/hold_screen.sh): per run, det success at x1-x8 and the physical figures.

    python experiments/screen_table.py runs/screen > results/screen/table.md"""

from __future__ import annotations

import json
import sys
from pathlib import Path

DAMPINGS = (1.0, 2.0, 4.0, 8.0)


def main(folder: str) -> None:
    print("| run | " + " | ".join(f"x{d:g}" for d in DAMPINGS) + " | x1 load p95 [N] | x8 load | palm x1 -> x8 [m/s] "
          "| penetration max [mm] | clip099 active | policy's own |")
    print("|---" * (7 + len(DAMPINGS)) + "|")
    for f in sorted(Path(folder).glob("*.eval.json")):
        c = {cell["damping"]: cell for cell in json.loads(f.read_text())["cells"]}
        print(f"| {f.name.removesuffix('.eval.json')} | " + " | ".join(f"{c[d]['success_rate']:.2f}" for d in DAMPINGS)
              + f" | {c[1.0]['wrist_load_peak_n']:.0f} | {c[8.0]['wrist_load_peak_n']:.0f} | "
              f"{c[1.0]['palm_speed_peak_m_s']:.2f} -> {c[8.0]['palm_speed_peak_m_s']:.2f} | "
              f"{max(cell['penetration_max_mm'] for cell in c.values()):.1f} | {c[1.0]['clip099_active']:.2f} | "
              f"{c[1.0]['clip099_policy_active']:.2f} |")


if __name__ == "__main__":
    main(sys.argv[1])
