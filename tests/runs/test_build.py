"""Assembly: a reference trajectory that moves another part than the default target makes that part the target."""

import pytest

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.evaluate import track
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.scene import build_scene
from dragmesh2_jax.task.config import TaskConfig
from dragmesh2_jax.task.env import PullTask
from dragmesh2_jax.trajectory.generator import generate
from dragmesh2_jax.trajectory.schema import write_trajectory


def test_a_trajectory_of_another_drawer_makes_that_drawer_the_target(tmp_path, capsys):
    obj = load_gapartnet(default_object())  # four drawers; the default target is the first
    assert obj.target.joint.name == "joint_d0"
    other = obj.with_target("joint_d2")
    assert other.target.part.link == "link_d2" and other.target.handle.link != obj.target.handle.link
    path = tmp_path / "d2.json"
    write_trajectory(generate(other), path)
    with pytest.raises(DragMeshError, match="with_target"):  # a scene of the default target is refused
        PullTask(build_scene(obj), generate(other), TaskConfig(backend="mujoco"))
    task = load_task(str(default_object()), str(path), backend="mujoco")
    assert task.scene.obj.target.joint.name == "joint_d2" and "it becomes the target" in capsys.readouterr().err
    assert track(task, [1.0])[0]["success_rate"] == 1.0  # the expert drag opens that drawer here
    with pytest.raises(DragMeshError, match="no annotated part is driven by joint 'nope'"):
        obj.with_target("nope")
