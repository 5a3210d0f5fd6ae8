"""The per-seed tables of RESULTS.md (experiments/seed_table.py): each cell the mean ± standard error over seeds
with every seed's value, read from reproduce's evaluation files; mixed protocols or none are an error."""

import json
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "seed_table.py"


def _evaluation(out: Path, method: str, seed: int, rates: dict, episodes=50):
    folder = out / "runs" / "door" / f"{method}_s{seed}" / "evaluations"
    folder.mkdir(parents=True, exist_ok=True)
    cells = [{"damping": d, "mode": "det", "success_rate": r} for d, r in rates.items()]
    protocol = {"episodes": episodes, "seed": 42, "starts": {"bank": 32, "seed": 12345}}
    (folder / f"best_robust__n{episodes}.json").write_text(json.dumps(
        {"object": "door", "label": method, "seed": seed, "cells": cells, "protocol": protocol}))


def _run(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True)


def test_a_cell_is_the_mean_and_standard_error_over_seeds_with_every_seeds_value(tmp_path):
    for seed, x8 in enumerate((0.0, 0.5, 1.0)):
        _evaluation(tmp_path, "hold", seed, {1.0: 1.0, 8.0: x8})
    (tmp_path / "main.json").write_text(json.dumps({"table": "main"}))  # reproduce's own record beside its runs
    res = _run(tmp_path, "--out", tmp_path / "t.md")
    assert res.returncode == 0 and "50 episodes per cell, perturbed starts (bank 32" in res.stdout
    row = next(line for line in (tmp_path / "t.md").read_text().splitlines() if line.startswith("| hold | det"))
    assert row == "| hold | det | 1.00 ± 0.00 (1.00, 1.00, 1.00) | 0.50 ± 0.29 (0.00, 0.50, 1.00) |"


def test_mixed_protocols_or_no_evaluations_are_an_error(tmp_path):
    assert _run(tmp_path).returncode == 2
    _evaluation(tmp_path, "hold", 0, {1.0: 1.0})
    _evaluation(tmp_path, "hold", 1, {1.0: 1.0}, episodes=20)
    res = _run(tmp_path)
    assert res.returncode == 2 and res.stderr.startswith("error: evaluations of several protocols")
