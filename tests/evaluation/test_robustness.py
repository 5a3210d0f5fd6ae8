"""``robustness(records, modes)`` (paper eq. robust): per mode in ``modes``, over that mode's damping cells, the mean
and the worst success rate and the mean active-joint clip rate, as Python floats; cells of other modes are ignored."""

import pytest

from dragmesh2_jax.evaluation.evaluate import robustness


def _cell(mode, damping, success, clip):
    return {"mode": mode, "damping": damping, "success_rate": success, "clip099_active": clip, "episodes": 4}


CELLS = [_cell("det", 1.0, 1.0, 0.1), _cell("stoch", 1.0, 0.75, 0.0), _cell("det", 2.0, 0.5, 0.2),
         _cell("det", 4.0, 0.25, 0.3), _cell("stoch", 4.0, 0.5, 0.5), _cell("noisy", 1.0, 0.0, 1.0)]


def test_mean_and_worst_success_per_mode():
    out = robustness(CELLS, ["det", "stoch"])
    assert list(out) == ["det", "stoch"]  # only the modes asked for, in their order
    assert out["det"] == pytest.approx({"mean_success": 1.75 / 3, "worst_success": 0.25, "clip099_active": 0.2})
    assert out["stoch"] == pytest.approx({"mean_success": 0.625, "worst_success": 0.5, "clip099_active": 0.25})
    assert all(type(v) is float for m in out.values() for v in m.values())


def test_one_cell_is_its_own_mean_and_worst():
    assert robustness(CELLS, ["noisy"]) == {"noisy": {"mean_success": 0.0, "worst_success": 0.0,
                                                      "clip099_active": 1.0}}
