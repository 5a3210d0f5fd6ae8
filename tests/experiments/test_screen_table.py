"""The lever screen's table (experiments/screen_table.py): one row per evaluated run, its det success at x1-x8 and
the physical figures read from the cells (the settled palm figure "-" where an evaluation has none), the penetration
the deepest of any damping."""

import json
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "screen_table.py"


def test_each_run_is_a_row_of_its_cells(tmp_path):
    def cell(d, success, pen):
        return {"damping": d, "mode": "det", "success_rate": success, "wrist_load_peak_n": 10.0 * d,
                "palm_speed_peak_m_s": 0.1 * d, "penetration_max_mm": pen, "clip099_active": 0.5,
                "clip099_policy_active": 0.25}
    cells = [cell(1.0, 1.0, 2.0), cell(2.0, 1.0, 2.5), cell(4.0, 0.5, 7.0), cell(8.0, 0.0, 3.0)]
    (tmp_path / "lever_door.eval.json").write_text(json.dumps({"cells": cells}))
    out = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path)], capture_output=True, text=True, check=True)
    header, rule, row = out.stdout.splitlines()
    assert header.count("|") == rule.count("|") == row.count("|") == 13
    assert row == "| lever_door | 1.00 | 1.00 | 0.50 | 0.00 | 10 | 80 | 0.10 -> 0.80 | - | 7.0 | 0.50 | 0.25 |"
    settled = [{**c, "palm_speed_settled_peak_m_s": 0.05 * c["damping"]} for c in cells]
    (tmp_path / "lever_door.eval.json").write_text(json.dumps({"cells": settled}))
    out = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path)], capture_output=True, text=True, check=True)
    assert "| 0.10 -> 0.80 | 0.05 -> 0.40 | 7.0 |" in out.stdout
