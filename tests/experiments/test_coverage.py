"""The coverage measurement (experiments/coverage.py): the quantities of the task's target, per procedural object in
both mixes and per real object (here the packaged procedural objects stand in for real ones), as JSON rows, a summary
table and a figure."""

import importlib.util
import json
import math
from pathlib import Path

from dragmesh2_jax.assets.procedural import default_objects

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "coverage.py"


def _script():
    spec = importlib.util.spec_from_file_location("coverage_script", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_object_gets_every_quantity_and_the_summary_a_row_per_quantity(tmp_path):
    cov = _script()
    real = default_objects()
    assert cov.main(["--procedural", "3", "--seed", "7", "--real", *map(str, real), "--out", str(tmp_path)]) == 0
    data = json.loads((tmp_path / "coverage.json").read_text())
    assert {m: len(v["objects"]) for m, v in data["mixes"].items()} == {"table1": 3, "all": 3}
    rows = data["rows"]
    assert sum(r["source"] == "real" for r in rows) == len(real) and not data["skipped"]
    for r in rows:
        assert set(data["quantities"]) <= set(r)
        for key in cov.NUMERIC:
            assert r[key] is None or math.isfinite(r[key]), (r["object"], key)
        assert all(r[key] is not None for key in cov.CATEGORICAL if key != "hinge_side")
        assert r["handle_length_m"] > 0 and r["part_mass_kg"] > 0 and r["part_width_m"] > 0
        if r["joint_type"] == "revolute":
            assert r["hinge_radius_m"] > 0 and r["joint_range_rad"] > 0 and r["hinge_side"] is not None
            assert r["joint_range_m"] is None
        else:
            assert r["hinge_radius_m"] is None and r["hinge_side"] is None and r["joint_range_m"] > 0
    by_name = {r["object"]: r for r in rows}
    # the packaged door cabinet (procedural, seed 0) is hinged on its right: a vertical bar on the left of the hinge
    door = by_name["door_cabinet_0000"]
    assert door["handle_type"] == "vertical bar" and door["hinge_side"] == "right"
    assert by_name["dishwasher_0000"]["hinge_side"] == "bottom"
    assert by_name["drawer_cabinet_0000"]["handle_type"] == "horizontal bar"
    blocks = (tmp_path / "coverage.md").read_text().split("\n\n")
    table = [line for line in blocks[1].splitlines() if line.startswith("| ")]
    assert len(table) == 1 + len(cov.CATEGORICAL) + len(cov.NUMERIC)  # the header, then a row per quantity
    assert all(line.count(" | ") == 2 + len(real) for line in table)  # quantity, two mixes, each real object
    same_type = [line for line in blocks[3].splitlines() if line.startswith("| ")]
    assert len(same_type) == 1 + len(real)  # the header, then a row per real object
    assert (tmp_path / "coverage.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
