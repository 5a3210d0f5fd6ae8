"""The validation suite of procedural doors (experiments/door_suite.py): chosen by the expert's envelope under a rule
written before the runs, every object rebuilt from its category and seed as it was measured."""

import importlib.util
import json
from pathlib import Path

import pytest

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.procedural import synthesize
from dragmesh2_jax.scene import build_scene

ROOT = Path(__file__).resolve().parents[2]
SUITE = ROOT / "results" / "suite" / "suite.json"
_spec = importlib.util.spec_from_file_location("door_suite", ROOT / "experiments" / "door_suite.py")
door_suite = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(door_suite)


def _envelope(opened: set[str]) -> dict[str, bool]:
    return {f"{p:g}@{d:g}": f"{p:g}@{d:g}" in opened for p in door_suite.PACES for d in door_suite.DAMPINGS}


def test_the_rule_names_a_door_that_lets_go_one_that_asks_for_pace_and_a_thick_handle_on_a_heavy_door():
    everywhere = {f"{p:g}@{d:g}" for p in door_suite.PACES for d in door_suite.DAMPINGS}
    light = door_suite.THICK / 2
    assert door_suite.classes(_envelope(everywhere), 0.5, light) == []
    hardest = everywhere - {"1@4", "0.33@8", "0.5@8", "1@8"}  # the paper's hardest door: x4 only at half pace
    assert door_suite.classes(_envelope(hardest), 0.5, light) == ["lets_go"]
    assert door_suite.classes(_envelope(everywhere - {"1@8"}), 0.5, light) == ["lags"]  # x8 only slower
    assert door_suite.classes(_envelope(everywhere), door_suite.HEAVY, door_suite.THICK) == ["thick_heavy"]


def test_the_suites_objects_build_and_load_as_they_were_measured(tmp_path):
    suite = json.loads(SUITE.read_text())
    objects = suite["objects"]
    assert len(objects) >= 20 and {o["category"] for o in objects} <= set(door_suite.CATEGORIES)
    assert any("lets_go" in o["classes"] or "lags" in o["classes"] for o in objects)
    for o in objects:
        (folder,) = synthesize(o["category"], 1, o["seed"], tmp_path / o["category"])
        scene = build_scene(load_gapartnet(str(folder)))
        assert scene.stats["target_mass_kg"] == pytest.approx(o["mass_kg"], abs=1e-4), o
        assert scene.handle.thickness == pytest.approx(o["handle_thickness_m"], abs=1e-4), o
