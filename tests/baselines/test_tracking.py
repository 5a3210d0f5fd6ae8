"""``tracking_delta``: the expert drag through the learned policies' action interface (target = q + alpha a);
``prior``: a residual method's expert prior alone."""

import dataclasses

import numpy as np
import pytest

from dragmesh2_jax.baselines.tracking import (
    drag_targets,
    prior_controller,
    tracking_controller,
    tracking_delta_controller,
)
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.rollout import cells, rollout
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.task.env import PullTask


def test_the_action_increments_suffice_to_open_a_door_at_x4(gapartnet_dir):
    """The expert drag sent as policy actions (target = q + alpha a, a in [-1, 1]) still opens the door 45780 at x4,
    with every step saturated: the increment interface does not cap the load a policy can pull against."""
    task = load_task(str(gapartnet_dir / "45780"), None, backend="mujoco")
    c = tracking_delta_controller(task)
    assert c.controls == "actions"
    out = cells(rollout(task, c.make_policy(True), c.params, [1.0, 4.0], 1, 0, c.controls, key=c.key), [1.0, 4.0], 1)
    assert [cell["success_rate"] for cell in out] == [1.0, 1.0]
    assert out[1]["clip099"] == 1.0


def test_a_slower_pace_is_the_same_path_in_more_steps(drawer_task):
    at_1, slow, fast = (drag_targets(drawer_task, p) for p in (1.0, 0.5, 2.0))
    assert len(at_1) > 10
    assert len(slow) == 2 * len(at_1) and len(fast) == round(len(at_1) / 2)
    for x in (slow, fast):  # same start and end, every target between two of the path's
        np.testing.assert_allclose(x[[0, -1]], at_1[[0, -1]], atol=1e-6)
        assert (x >= at_1.min(0) - 1e-6).all() and (x <= at_1.max(0) + 1e-6).all()
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(DragMeshError, match="pace"):
            drag_targets(drawer_task, bad)


def test_the_prior_alone_is_the_residual_at_zero_and_on_the_target_it_is_the_tracking_replay(drawer_task):
    """The prior of a residual on the drag's target, its residual at zero, opens the drawer as the tracking replay
    does, in the same steps; a task without an expert prior has none to evaluate."""
    with pytest.raises(DragMeshError, match="expert prior"):
        prior_controller(drawer_task)
    config = dataclasses.replace(drawer_task.config, expert_prior=True, residual_on="target")
    task = PullTask(drawer_task.scene, drawer_task.traj, config)
    out = {}
    for c in (prior_controller(task), tracking_controller(task)):
        out[c.name] = cells(rollout(task, c.make_policy(True), c.params, [1.0], 1, 0, c.controls, key=c.key), [1.0],
                            1)[0]
    assert out["prior"]["success_rate"] == out["tracking"]["success_rate"] == 1.0
    assert out["prior"]["steps_mean"] == out["tracking"]["steps_mean"]
