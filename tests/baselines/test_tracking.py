"""``tracking_delta``: the expert drag through the learned policies' action interface (target = q + alpha a)."""

from dragmesh2_jax.baselines.tracking import tracking_delta_controller
from dragmesh2_jax.evaluation.rollout import cells, rollout
from dragmesh2_jax.runs.build import load_task


def test_the_action_increments_suffice_to_open_a_door_at_x4(gapartnet_dir):
    """The expert drag sent as policy actions (target = q + alpha a, a in [-1, 1]) still opens the door 45780 at x4,
    with every step saturated: the increment interface does not cap the load a policy can pull against."""
    task = load_task(str(gapartnet_dir / "45780"), None, backend="mujoco")
    c = tracking_delta_controller(task)
    assert c.controls == "actions"
    out = cells(rollout(task, c.make_policy(True), c.params, [1.0, 4.0], 1, 0, c.controls, key=c.key), [1.0, 4.0], 1)
    assert [cell["success_rate"] for cell in out] == [1.0, 1.0]
    assert out[1]["clip099"] == 1.0
