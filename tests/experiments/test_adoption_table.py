"""The adoption table (experiments/adoption_table.py): per object over its seeds' runs, the policy beside its expert
from the same starts, and the rule's clauses it misses; a run without both evaluations is listed as missing."""

import json
import subprocess
import sys
from pathlib import Path

from dragmesh2_jax.runs.overrides import RECIPE_DAMPINGS

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "adoption_table.py"
sys.path.insert(0, str(SCRIPT.parent))
from adoption_table import EXPERT, POLICY  # noqa: E402


def _cell(d: float, success: float, load: float, palm: float, pen: float, own: float = 0.1) -> dict:
    return {"damping": d, "mode": "det", "success_rate": success, "wrist_load_peak_n": load,
            "palm_speed_settled_peak_m_s": palm, "palm_speed_peak_m_s": 2 * palm, "penetration_p95_mm": pen + 0.5,
            "penetration_settled_p95_mm": pen,
            "penetration_max_mm": 3 * pen, "clip099_policy_active": own}


def _run(root: Path, name: str, load: float, x8_palm: float, expert: bool = True, prior: float | None = None) -> Path:
    run = root / name
    (run / "evaluations").mkdir(parents=True)
    cells = [_cell(d, 1.0, load, x8_palm if d == 8.0 else 0.1, 1.0) for d in RECIPE_DAMPINGS]
    (run / "evaluations" / f"final__{POLICY.name}.json").write_text(json.dumps({"cells": cells}))
    if expert:
        cells = [_cell(d, 1.0, 40.0, 0.1, 1.5) for d in EXPERT.dampings]
        (run / "evaluations" / f"tracking__{EXPERT.name}.json").write_text(json.dumps({"cells": cells}))
    if prior is not None:  # the residual method's prior alone: the expert in use where a run has it
        cells = [_cell(d, 1.0, prior, 0.1, 1.5) for d in EXPERT.dampings]
        (run / "evaluations" / f"prior__{EXPERT.name}.json").write_text(json.dumps({"cells": cells}))
    return run


def test_each_object_is_judged_against_its_own_expert_over_its_seeds(tmp_path):
    runs = [_run(tmp_path, f"45780_hold_blind_residual_target_s{s}", 40.0 + 2 * s, 0.1) for s in range(3)]
    runs += [_run(tmp_path, f"door_cabinet_0000_hold_blind_residual_target_s{s}", 40.0, 0.1 + 0.1 * s)
             for s in range(2)]
    runs.append(_run(tmp_path, "11712_hold_blind_residual_target_s0", 40.0, 0.1, expert=False))
    runs.append(_run(tmp_path, "45780_hold_blind_residual_follow_s0", 40.0, 0.1, prior=20.0))  # another method
    out = subprocess.run([sys.executable, str(SCRIPT), *map(str, runs)], capture_output=True, text=True, check=True,
                         cwd="/")
    header, _, *lines = out.stdout.splitlines()
    follow = next(line for line in lines if "(20; 2.00x)" in line)
    assert follow.startswith("| 45780 | 1 |") and follow.endswith("| load |")  # against its prior, not the replay
    lines.remove(follow)
    by_object = {line.split(" | ")[0][2:]: line for line in lines}
    assert len(lines) == 3
    assert header.count("|") == 9
    assert "42 (40; 1.05x)" in by_object["45780"] and by_object["45780"].endswith("| all met |")
    assert "0.10 / 0.10 / 0.15" in by_object["door_cabinet_0000"]  # x8 the mean of 0.1 and 0.2: past 1.1x x1
    assert by_object["door_cabinet_0000"].endswith("| palm |")
    assert "missing evaluations (1 of 2)" in by_object["11712"]
    bad = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path / "no_seed")], capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.startswith("error: ")
