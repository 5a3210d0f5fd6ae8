"""The evaluation protocol: rates with Wilson intervals, clip099 over all and over active DoFs, a policy
function as the only interface, det cells that are distributions from perturbed starts."""

import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.evaluation.evaluate import markdown_table, rollout_cells, wilson_interval
from dragmesh2_jax.runs import eval_task


def test_wilson_interval():
    lo, hi = wilson_interval(0, 20)
    assert lo == 0.0 and hi == pytest.approx(0.1611, abs=1e-3)
    lo, hi = wilson_interval(20, 20)
    assert lo == pytest.approx(0.8389, abs=1e-3) and hi == 1.0
    lo, hi = wilson_interval(10, 20)
    assert lo == pytest.approx(0.2993, abs=1e-3) and hi == pytest.approx(0.7007, abs=1e-3)


def _pull_policy(task, locked_value):
    """A controller as a policy function: pull along the handle normal; locked axes get ``locked_value``."""
    from dragmesh2_jax.assets.hand import active_dofs

    a = np.where(active_dofs(), 0.0, locked_value).astype(np.float32)
    a[:3] = 0.5 * task.scene.handle.normal

    def policy(params, obs, key):
        return jnp.broadcast_to(jnp.asarray(a) * params, (obs.state.shape[0], 51))

    return policy


def test_clip099_counts_all_channels_and_active_ones_separately(drawer_task):
    task = eval_task(drawer_task)
    cells = rollout_cells(task, _pull_policy(task, locked_value=1.0), jnp.float32(1.0), [1.0], episodes=4)
    c = cells[0]
    assert c["clip099"] == 1.0  # a saturated locked axis saturates the all-channel figure...
    assert c["clip099_active"] == 0.0  # ...but moves nothing: the active-DoF figure sees no saturation
    cells = rollout_cells(task, _pull_policy(task, locked_value=0.0), jnp.float32(1.0), [1.0], episodes=4)
    assert cells[0]["clip099"] == 0.0


def test_cells_report_rates_with_intervals(drawer_task):
    task = eval_task(drawer_task)
    cells = rollout_cells(task, _pull_policy(task, 0.0), jnp.float32(1.0), [1.0, 4.0], episodes=6, seed=3)
    assert [c["damping"] for c in cells] == [1.0, 4.0]
    for c in cells:
        assert c["episodes"] == 6 and c["success_rate"] == c["successes"] / 6
        lo, hi = c["success_ci95"]
        assert lo <= c["success_rate"] <= hi
        assert 1 <= c["steps_mean"] <= task.config.episode_length and c["action_l2_mean"] > 0
    md = markdown_table({"cells": [{**c, "mode": "det"} for c in cells],
                         "robustness": {"det": {"mean_success": 0.5, "worst_success": 0.0, "clip099_active": 0.0}}})
    assert "clip099 active" in md and "[" in md
