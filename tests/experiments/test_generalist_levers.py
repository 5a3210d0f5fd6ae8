"""The levers' table (experiments/generalist_levers.py): policies named ARM_sSEED grouped by arm, each column the mean
± standard error over seeds (with every seed's value) of a seed's mean over the test set or the shared objects."""

import importlib.util
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "generalist_levers.py"
spec = importlib.util.spec_from_file_location("generalist_levers", SCRIPT)
levers = importlib.util.module_from_spec(spec)
spec.loader.exec_module(levers)


def _cells(x1: float, x4: float) -> list[dict]:
    return [{"damping": 1.0, "mode": "det", "success_rate": x1}, {"damping": 4.0, "mode": "det", "success_rate": x4}]


def test_an_arm_s_cell_is_the_spread_of_its_seeds_means_over_the_test_set_and_the_shared_objects():
    kinds = {"door_3000": "test", "table_3000": "test", **{o: "shared" for o in levers.SHARED_OBJECTS}}
    shared = {o: _cells(1.0, 0.5) for o in levers.SHARED_OBJECTS}
    rows = {"ppo_s0": {"door_3000": _cells(0.0, 0.0), "table_3000": _cells(1.0, 1.0), **shared},
            "ppo_s1": {"door_3000": _cells(1.0, 0.0), "table_3000": _cells(1.0, 1.0), **shared},
            "curriculum_s0": {"door_3000": _cells(1.0, 1.0), "table_3000": _cells(1.0, 1.0), **shared}}
    lines = levers.table(rows, kinds, (1.0, 4.0)).splitlines()
    assert lines[0] == "| arm | seeds | test set x1 | test set x4 | shared objects x1 | shared objects x4 |"
    assert lines[2] == ("| ppo | 2 | 0.75 ± 0.25 (0.50, 1.00) | 0.50 ± 0.00 (0.50, 0.50) | 1.00 ± 0.00 (1.00, 1.00) "
                        "| 0.50 ± 0.00 (0.50, 0.50) |")
    assert lines[3].startswith("| curriculum | 1 | 1.00 ± 0.00 (1.00) | 1.00 ± 0.00 (1.00) |")
    by_category = next(line for line in lines if line.startswith("| ppo | 0.50 / 0.00"))
    assert by_category == "| ppo | 0.50 / 0.00 | 1.00 / 1.00 |"  # door, then table
