"""The GT-part-pose parallel-jaw primitive: its own gripper, the same evaluator, and it opens a drawer."""

import numpy as np

from dragmesh2_jax.assets import gripper
from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.baselines.parallel_jaw import PARALLEL_JAW, jaw_frame, parallel_jaw, primitive_plan
from dragmesh2_jax.evaluation.evaluate import evaluate
from dragmesh2_jax.evaluation.protocol import EvalProtocol
from tests.conftest import installed_command


def test_the_gripper_task_and_plan(drawer_task):
    task, controller = parallel_jaw(drawer_task)
    assert task.action_size == gripper.NUM_DOFS == 8 and task.scene.config.effector == PARALLEL_JAW
    assert controller.controls == "targets" and controller.params.shape == (task.config.episode_length, 8)
    assert task.params.q_done == drawer_task.params.q_done  # the reference trajectory's task boundary
    R = jaw_frame(task.scene.handle)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-9)
    np.testing.assert_allclose(R[:, 2], -task.scene.handle.normal, atol=1e-9)  # fingers reach into the handle
    start, targets = primitive_plan(task.scene, 120)
    assert np.all(start[6:] == gripper.FINGER_TRAVEL) and np.all(targets[-1, 6:] == 0.0)  # opens, then closes
    h = task.scene.handle
    assert np.linalg.norm(start[:3] - h.centre) > np.linalg.norm(targets[40, :3] - h.centre)  # moved in
    assert (targets[-1, :3] - targets[50, :3]) @ h.normal > 0.05  # then pulled out along the drawer's axis


def test_it_opens_the_procedural_drawer_at_x1(drawer_task, capsys):
    protocol = EvalProtocol(dampings=(1.0,), modes=("det",), episodes=2, starts=None)
    task, controller = parallel_jaw(protocol.task(drawer_task))
    res = evaluate(task, controller, protocol)
    (cell,) = res["cells"]
    assert res["method"] == PARALLEL_JAW and cell["success_rate"] == 1.0 and cell["detach_rate"] == 0.0
    dragmesh2 = installed_command()  # the same through the command, from the protocol's perturbed starts
    assert dragmesh2(["evaluate", "--method", "parallel_jaw", "--object", str(default_object()), "--damping", "1",
                      "--mode", "det", "--episodes", "4", "--backend", "mujoco", "--json"]) == 0
    out = capsys.readouterr().out
    assert '"method": "parallel_jaw"' in out and '"success_rate": 1.0' in out
