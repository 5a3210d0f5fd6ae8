"""Whether a constraint's budget is met by the end of training (experiments/constraint_table.py): the mean epoch
cost over the last epochs against the budget, with the multiplier and its rise over them, and on which actions the
cost was counted."""

import csv
import json
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "constraint_table.py"


def _run_folder(out: Path, name: str, costs: list[float], lr: float = 2.0, budget: float = 0.02, mean_share=None):
    folder = out / name
    folder.mkdir(parents=True)
    constraint = {"measure": "relative_load", "limit": 1.0, "cost": "rate", "budget": budget}
    record = {"task": {"reward": {"constraints": [constraint]}}}  # a run from before mean_share has no such field
    if mean_share is not None:
        record["ppo"] = {"mean_share": mean_share}
    (folder / "run.json").write_text(json.dumps(record))
    lam, rows = 0.0, []
    for epoch, c in enumerate(costs, 1):
        lam = max(lam + lr * (c - budget), 0.0)
        rows.append({"epoch": epoch, "cost_relative_load": c, "lambda_relative_load": lam})
    with open(folder / "log.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def _table(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True)


def test_a_budget_met_at_the_end_and_one_still_broken_are_told_apart(tmp_path):
    _run_folder(tmp_path, "door_s0", [0.3] * 20 + [0.01] * 10)  # broken early, met over the last 10 epochs
    _run_folder(tmp_path, "door_s1", [0.3] * 20 + [0.07] * 10, mean_share=0.0)  # past it: 9 x 2 x 0.05 over the last 10
    _run_folder(tmp_path, "door_s3", [0.01] * 10, mean_share=0.125)
    _run_folder(tmp_path, "door_s2", [0.3])
    (tmp_path / "door_s2" / "log.csv").unlink()  # started, its first epoch not logged yet: no line
    res = _table(tmp_path, "--row", "bound=door_s*")
    assert res.returncode == 0, res.stderr
    met, broken, mean = [line for line in res.stdout.splitlines() if line.startswith("| bound |")]
    assert "| door_s0 | relative_load (rate; sampled) | 0.02 | 0.0100 | yes | 11.0 (-0.2) |" in met
    assert "| door_s1 | relative_load (rate; sampled) | 0.02 | 0.0700 | no | 12.2 (+0.9) |" in broken
    assert "| door_s3 | relative_load (rate; mean) | 0.02 | 0.0100 | yes | 0.0 (+0.0) |" in mean


def test_a_glob_that_matches_no_run_is_an_error(tmp_path):
    res = _table(tmp_path, "--row", "bound=nothing*")
    assert res.returncode != 0 and "error: no run folder matches" in res.stderr
