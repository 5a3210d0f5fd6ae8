"""From what a run is to what computes it: an object folder (and a trajectory, generated when not given) becomes a
task; a :class:`~dragmesh2_jax.runs.spec.RunSpec` becomes a training program."""

from __future__ import annotations

from dragmesh2_jax.ppo.train import TrainProgram, make_train
from dragmesh2_jax.runs.spec import RunSpec
from dragmesh2_jax.scene import TEMPLATE_SLOTS, SceneConfig
from dragmesh2_jax.task.config import TaskConfig
from dragmesh2_jax.task.env import PullTask
from dragmesh2_jax.task.load import task_of
from dragmesh2_jax.task.mix import ObjectMix
from dragmesh2_jax.trajectory.schema import Trajectory


def load_task(object_dir: str, trajectory: str | Trajectory | None = None, backend: str = "auto", impl: str = "auto",
              scene_config: SceneConfig | None = None, slots: int | None = None, **task_fields) -> PullTask:
    """:func:`task_of` with the default config and ``task_fields`` on top (validated before anything compiles)."""
    config = TaskConfig(backend=backend, impl=impl, **task_fields)
    return task_of(object_dir, trajectory, config, scene_config or SceneConfig(), slots)


TrajectoryArg = str | Trajectory | None


def template_slots(objects: int, config: TaskConfig) -> int | None:
    """The one-structure template's slots for ``objects`` objects on ``config``'s engine: MJX stacks the models of a
    mix, so several objects there are built on it (``scene.build_scene``); the C engine and one object keep their own
    structure (None)."""
    return TEMPLATE_SLOTS if objects > 1 and config.resolved_backend() == "mjx" else None


def tasks_of(spec: RunSpec, trajectories: TrajectoryArg | list[TrajectoryArg] = None) -> list[PullTask]:
    """One task per object of ``spec`` (training objects, then held-aside ones), each on its trajectory (a file, a
    trajectory, or None: generated); a single trajectory is the first object's."""
    objects = spec.objects or (spec.object,)
    trajs = list(trajectories) if isinstance(trajectories, list | tuple) else [trajectories]
    trajs += [None] * (len(objects) - len(trajs))
    slots = template_slots(len(objects), spec.task)
    return [task_of(o, t, spec.task, spec.scene, slots) for o, t in zip(objects, trajs, strict=True)]


def mix_of(tasks: list[PullTask]) -> PullTask | ObjectMix:
    return tasks[0] if len(tasks) == 1 else ObjectMix(tasks)


def programs_of(spec: RunSpec, trajectories: TrajectoryArg | list[TrajectoryArg] = None
                ) -> tuple[TrainProgram, PullTask | ObjectMix | None, list[PullTask]]:
    """The training program of ``spec`` (over its training objects), the held-aside objects' env that chooses its
    checkpoints (None: the training env itself) and every object's task."""
    tasks = tasks_of(spec, trajectories)
    n = len(tasks) - spec.holdout
    program = make_train(mix_of(tasks[:n]), spec.network, spec.ppo, spec.method)
    return program, (mix_of(tasks[n:]) if spec.holdout else None), tasks


def program_of(spec: RunSpec, trajectories: TrajectoryArg | list[TrajectoryArg] = None) -> TrainProgram:
    """The training program of ``spec`` (its task on its trajectories, generated where None)."""
    return programs_of(spec, trajectories)[0]
