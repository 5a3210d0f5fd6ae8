"""From what a run is to what computes it: an object folder (and a trajectory, generated when not given) becomes a
task; a :class:`~dragmesh2_jax.runs.spec.RunSpec` becomes a training program."""

from __future__ import annotations

import sys

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.ppo.train import TrainProgram, make_train
from dragmesh2_jax.runs.spec import RunSpec
from dragmesh2_jax.scene import SceneConfig, build_scene
from dragmesh2_jax.task.config import TaskConfig
from dragmesh2_jax.task.env import PullTask, trajectory_joint
from dragmesh2_jax.trajectory.generator import generate
from dragmesh2_jax.trajectory.schema import Trajectory, read_trajectory


def adopt_trajectory_target(obj, traj: Trajectory):
    """The object with the part ``traj`` moves as its target (paper §3.1: the target joint is the DoF with the
    largest motion range in the reference trajectory), saying so when that is not the default target."""
    moved = trajectory_joint(obj, traj)
    if moved != obj.target.joint.name:
        print(f"note: the trajectory moves joint {moved} of object {obj.object_id}; it becomes the target (the "
              f"default target was {obj.target.joint.name})", file=sys.stderr)
    return obj.with_target(moved)


def task_of(object_dir: str, trajectory: str | Trajectory | None, config: TaskConfig,
            scene_config: SceneConfig = SceneConfig()) -> PullTask:
    """Object + trajectory (a file, a trajectory, or None: generated) -> the task, in ``scene_config``."""
    if not object_dir:
        raise DragMeshError("no object folder given (--object)")
    obj = load_gapartnet(object_dir)
    traj = read_trajectory(trajectory) if isinstance(trajectory, str) else trajectory
    if traj is not None:
        obj = adopt_trajectory_target(obj, traj)
    scene = build_scene(obj, scene_config)
    return PullTask(scene, generate(obj, scene=scene) if traj is None else traj, config)


def load_task(object_dir: str, trajectory: str | Trajectory | None = None, backend: str = "auto", impl: str = "jax",
              scene_config: SceneConfig | None = None, **task_fields) -> PullTask:
    """:func:`task_of` with the default config and ``task_fields`` on top (validated before anything compiles)."""
    config = TaskConfig(backend=backend, impl=impl, **task_fields)
    return task_of(object_dir, trajectory, config, scene_config or SceneConfig())


def program_of(spec: RunSpec, trajectory: str | Trajectory | None = None) -> TrainProgram:
    """The training program of ``spec`` (its task on ``trajectory``, generated when None)."""
    return make_train(task_of(spec.object, trajectory, spec.task, spec.scene), spec.preset, spec.ppo)
