"""The recipe's table (experiments/recipe_table.py): per object its runs and the previous recipe's, success at each
damping as the mean over seeds with the lowest seed beside it, the physical figures averaged, the penetration the
deepest of any cell, the policy's own saturation where the evaluations count it."""

import json
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "recipe_table.py"


def _evaluation(path: Path, successes: dict[float, float], load: float, own: bool) -> None:
    cells = [{"damping": d, "mode": "det", "success_rate": s, "wrist_load_peak_n": load * d,
              "palm_speed_peak_m_s": 0.1 * d, "penetration_max_mm": 2.0 * d, **({"clip099_policy_active": 0.2}
                                                                                 if own else {})}
             for d, s in successes.items()]
    path.write_text(json.dumps({"cells": cells}))


def test_each_object_is_its_row_over_seeds_and_the_previous_recipe_beneath_it(tmp_path):
    for seed, x8 in enumerate((1.0, 0.5)):
        _evaluation(tmp_path / f"new_s{seed}.json", {1.0: 1.0, 2.0: 1.0, 4.0: 1.0, 8.0: x8}, 10.0 + 10 * seed, True)
        _evaluation(tmp_path / f"old_s{seed}.json", {1.0: 1.0, 2.0: 1.0, 4.0: 0.0, 8.0: 0.0, 16.0: 0.0}, 50.0, False)
    rows = tmp_path / "rows.json"
    rows.write_text(json.dumps([{"object": "door", "grasp": "seated", "runs": str(tmp_path / "new_s*.json"),
                                 "before": str(tmp_path / "old_s*.json")}]))
    out = subprocess.run([sys.executable, str(SCRIPT), str(rows)], capture_output=True, text=True, check=True,
                         cwd="/")
    header, rule, new, old = out.stdout.splitlines()
    assert header.count("|") == rule.count("|") == new.count("|") == old.count("|") == 11
    assert new == "| door (seated) | 1.00 | 1.00 | 1.00 | 0.75 (0.50) | - | 15 | 0.10 -> 0.80 | 16.0 | 0.20 |"
    assert old == "|   previous recipe | 1.00 | 1.00 | 0.00 | 0.00 | 0.00 | 50 | 0.10 -> 0.80 | 32.0 | - |"
    rows.write_text(json.dumps([{"object": "door", "grasp": "seated", "runs": str(tmp_path / "none*.json"),
                                 "before": str(tmp_path / "old_s*.json")}]))
    missing = subprocess.run([sys.executable, str(SCRIPT), str(rows)], capture_output=True, text=True, cwd="/")
    assert missing.returncode != 0 and "error: no evaluation files match" in missing.stderr
