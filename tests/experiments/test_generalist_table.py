"""The generalist table (experiments/generalist_table.py): each run's latest zero-shot evaluation per shared object,
every cell the mean ± standard error over seeds with every seed's value, the average over the objects per seed, and
the issue's target checked on the det means; a missing evaluation is one error line."""

import json
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "generalist_table.py"
OBJECTS = ("45261", "45661", "45780", "11712")
FIGURES = {"wrist_load_peak_n": 150.0, "palm_speed_peak_m_s": 1.0, "steps_mean": 10.0, "detach_rate": 0.0,
           "clip099_active": 1.0, "penetration_max_mm": 8.0}


def _run_folder(root: Path, seed: int, x4: dict) -> Path:
    run = root / f"generalist_s{seed}"
    (run / "evaluations").mkdir(parents=True)
    for oid in OBJECTS:
        cells = [{"mode": m, "damping": d, "success_rate": x4[oid] if d == 4.0 else 1.0, **FIGURES}
                 for m in ("det", "stoch") for d in (1.0, 4.0)]
        (run / "evaluations" / f"final__n20__on-{oid}.json").write_text(json.dumps(
            {"cells": cells, "protocol": {"episodes": 20}}))
    return run


def _table(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True)


def test_cells_are_spread_over_seeds_and_the_target_reads_the_det_means(tmp_path):
    runs = [_run_folder(tmp_path, 0, {"45261": 1.0, "45661": 1.0, "45780": 0.4, "11712": 0.8}),
            _run_folder(tmp_path, 1, {"45261": 1.0, "45661": 1.0, "45780": 0.8, "11712": 0.8})]
    res = _table(*runs)
    assert res.returncode == 0, res.stderr
    lines = res.stdout.strip().splitlines()
    assert "| 45780 | det | 1.00 ± 0.00 (1.00, 1.00) | 0.60 ± 0.20 (0.40, 0.80) |" in lines
    assert "| average | det | 1.00 ± 0.00 (1.00, 1.00) | 0.85 ± 0.05 (0.80, 0.90) |" in lines
    assert lines[-1].startswith("Target (det, means over 2 seeds): x1 1.00 (>= 0.85), x4 0.85 (>= 0.7), lowest "
                                "object at x4 45780 0.60 (>= 0.5): met")
    low = _run_folder(tmp_path / "low", 2, {"45261": 1.0, "45661": 1.0, "45780": 0.2, "11712": 0.8})
    assert _table(low).stdout.strip().splitlines()[-1].endswith("45780 0.20 (>= 0.5): not met")


def test_a_run_without_an_evaluation_on_every_object_is_one_error_line(tmp_path):
    run = _run_folder(tmp_path, 0, dict.fromkeys(OBJECTS, 1.0))
    (run / "evaluations" / "final__n20__on-11712.json").unlink()
    res = _table(run)
    assert res.returncode == 2 and res.stderr == f"error: {run}: no zero-shot evaluation of final on 11712\n"


def test_the_fine_tuned_rows_come_from_the_seeds_fine_tuned_on_every_object(tmp_path):
    run = _run_folder(tmp_path, 0, dict.fromkeys(OBJECTS, 1.0))
    ft = tmp_path / "ft"
    ft.mkdir()
    for seed, x4 in ((0, 0.5), (1, 1.0), (2, 1.0)):
        for oid in OBJECTS if seed < 2 else OBJECTS[:1]:  # seed 2 fine-tuned on one object only: left out
            cells = [{"mode": "det", "damping": d, "success_rate": x4 if d == 4.0 else 1.0, **FIGURES}
                     for d in (1.0, 4.0)]
            (ft / f"ft_{oid}_s{seed}.json").write_text(json.dumps({"cells": cells}))
    res = _table(run, "--finetuned", ft)
    assert res.returncode == 0, res.stderr
    tail = res.stdout.split("Fine-tuned 20 epochs on each object (2 seeds):", 1)[1].splitlines()
    assert "| 45780 | det | 1.00 ± 0.00 (1.00, 1.00) | 0.75 ± 0.25 (0.50, 1.00) |" in tail
