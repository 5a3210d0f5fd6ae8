"""The residual generalist's screen (experiments/generalist_residual.py): two arms at one budget over the
generalist's objects, each zero-shot on the shared objects; its table puts every arm and object on a row with success
at each damping and the physical figures beside it."""

import importlib.util
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "generalist_residual.py"
_spec = importlib.util.spec_from_file_location("generalist_residual", SCRIPT)
generalist_residual = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(generalist_residual)


def _cells(successes, load, own):
    return [{"damping": d, "success_rate": s, "wrist_load_peak_n": load * d, "palm_speed_peak_m_s": 0.1 * d,
             "penetration_max_mm": 2.0 * d, "clip099_active": 0.9, **({"clip099_policy_active": own} if own else {})}
            for d, s in successes.items()]


def test_each_arm_and_object_is_a_row_with_its_success_and_how_it_was_opened():
    rows = {"generalist": {"45780": _cells({1.0: 1.0, 4.0: 0.5, 8.0: 0.0}, 150.0, None)},
            "residual": {"45780": _cells({1.0: 1.0, 4.0: 1.0, 8.0: 0.96}, 20.0, 0.1)}}
    header, rule, scratch, residual = generalist_residual.table(rows, [1.0, 4.0, 8.0]).splitlines()
    assert header.startswith("| arm | object | x1 | x4 | x8 |") and rule.count("---") == 9
    assert scratch == ("| generalist | 45780 | 1.00 | 0.50 | 0.00 | 150 / 1200 | 0.10 -> 0.80 | 16.0 | 0.90 / 0.90 |")
    assert residual == "| residual | 45780 | 1.00 | 1.00 | 0.96 | 20 / 160 | 0.10 -> 0.80 | 16.0 | 0.90 / 0.10 |"
    assert generalist_residual.ARMS == {"generalist": "generalist", "residual": "generalist_residual"}


def test_over_seeds_each_arm_and_object_is_the_mean_and_standard_error_with_every_seed():
    screens = [{"residual": {"11712": _cells({1.0: 1.0, 8.0: x8}, load, 0.1)}}
               for x8, load in ((1.0, 20.0), (0.5, 40.0), (0.0, 60.0))]
    screens[1]["generalist"] = {"11712": _cells({1.0: 0.5, 8.0: 0.0}, 150.0, None)}  # one seed only
    header, rule, residual, scratch = generalist_residual.seeds_table(screens, [1.0, 8.0]).splitlines()
    assert header.startswith("| arm | object | seeds | x1 | x8 |")
    assert residual == ("| residual | 11712 | 3 | 1.00 ± 0.00 (1.00, 1.00, 1.00) | 0.50 ± 0.29 (1.00, 0.50, 0.00) "
                        "| 40 / 320 | 0.10 -> 0.80 | 16.0 |")
    assert scratch.startswith("| generalist | 11712 | 1 | 0.50 ± 0.00 (0.50) | 0.00 ± 0.00 (0.00) | 150 / 1200 |")


def test_the_rule_adopts_only_what_beats_the_packaged_generalist_at_x4_and_x8_within_the_force_clause():
    """Load and palm relative to the expert's at x1: on 45780 1.15x the load and 2x the palm pass; on 11712 a pull of
    1.25x the expert's fails though every damping opens."""
    dampings = {1.0: 1.0, 4.0: 1.0, 8.0: 0.9}
    screens = [{"residual": {"45780": _cells(dampings, 11.5, 0.1), "11712": _cells(dampings, 25.0, 0.1)}}
               for _ in range(3)]
    screens[0]["expert"] = {o: _cells({1.0: 1.0, 4.0: 1.0, 8.0: 1.0}, 10.0 if o == "45780" else 20.0, None)
                            for o in ("45780", "11712")}
    for o in ("45780", "11712"):  # the palm at x8 0.8 m/s: twice the expert's at x1
        screens[0]["expert"][o][0]["palm_speed_peak_m_s"] = 0.4
    packaged = {"objects": {o: [{"damping": d, "mode": m, "success_rate": s} for d, s in ((4.0, 0.65), (8.0, 0.0))
                                for m in ("det", "stoch")] for o in ("45780", "11712")}}
    header, rule, door, fridge = generalist_residual.rule_table(screens, packaged).splitlines()
    assert header.startswith("| object | seeds | x4 (packaged) | x8 (packaged) |")
    assert door == "| 45780 | 3 | 1.00 (0.65) | 0.90 (0.00) | 1.15 (<= 1.2) | 2.00 (<= 2) | yes |"
    assert fridge == "| 11712 | 3 | 1.00 (0.65) | 0.90 (0.00) | 1.25 (<= 1.2) | 2.00 (<= 2) | no |"
