"""A task from an object folder and a reference trajectory: what a run builds for each of its objects
(``runs/build.py``) and what the task's own envs build from their config (``task/playground.py``)."""

from __future__ import annotations

import sys
from dataclasses import replace

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.hand import HandConfig
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.scene import SceneConfig, build_scene
from dragmesh2_jax.task import choice
from dragmesh2_jax.task.config import TaskConfig
from dragmesh2_jax.task.env import PullTask, trajectory_joint
from dragmesh2_jax.trajectory import grasp
from dragmesh2_jax.trajectory.generator import SEAT_DEPTH, GeneratorParams, generate, holds
from dragmesh2_jax.trajectory.rest import rested
from dragmesh2_jax.trajectory.schema import Trajectory, read_trajectory


def adopt_trajectory_target(obj, traj: Trajectory):
    """The object with the part ``traj`` moves as its target (paper §3.1: the target joint is the DoF with the
    largest motion range in the reference trajectory), saying so when that is not the default target."""
    moved = trajectory_joint(obj, traj)
    if moved != obj.target.joint.name:
        print(f"note: the trajectory moves joint {moved} of object {obj.object_id}; it becomes the target (the "
              f"default target was {obj.target.joint.name})", file=sys.stderr)
    return obj.with_target(moved)


def generator_params(config: TaskConfig) -> GeneratorParams:
    """How the task's trajectory is generated where none is given: its expert grasp and placement."""
    return GeneratorParams(seat_depth=SEAT_DEPTH if config.expert_grasp == "seated" else None,
                           grip_closure=config.grip_closure,
                           placement_choice="holds" if config.expert_placement == "holds" else "first",
                           hold_steps=config.episode_length,
                           placements=GeneratorParams().placements + (grasp.WRAPS if config.expert_wrap else ()))


def plan_scene_config(config: TaskConfig, scene_config: SceneConfig) -> SceneConfig:
    """The scene the task's trajectory is generated in: ``scene_config``, or under ``expert_plan_contact`` "mujoco"
    that scene with MuJoCo's default object contacts and the hand's default finger drives (under "holds", the second
    of the two it may be generated in)."""
    if config.expert_plan_contact == "scene":
        return scene_config
    hand = replace(scene_config.hand, finger=HandConfig().finger)
    return replace(scene_config, object_contact=SceneConfig().object_contact, hand=hand)


def generated_as_planned(config: TaskConfig) -> bool:
    """Whether :func:`generated` returns the generator's trajectory in the plan scene as it is: no choice between
    physics or among placements made here, and no rest."""
    return (config.expert_plan_contact != "holds" and config.expert_placement not in choice.PLACEMENTS
            and not config.expert_rest)


def generated(obj, scene, config: TaskConfig, slots: int | None = None) -> Trajectory:
    """The task's trajectory, generated under ``config``'s grasp in ``plan_scene_config``'s scene; under
    ``expert_plan_contact`` "holds" in both, the one planned in ``scene`` kept unless the other, replayed in
    ``scene``, holds the part at a higher damping (``trajectory.generator.holds``); under ``expert_placement``
    "starts" (or "starts_hold") each placement generated alone in each, the one kept by ``task.choice``; under
    ``expert_rest`` the one kept rested on ``scene``'s contacts (``trajectory.rest``)."""
    params = generator_params(config)
    planned_in = plan_scene_config(config, scene.config)
    other = scene if planned_in == scene.config else build_scene(obj, planned_in, slots=slots)
    if config.expert_placement in choice.PLACEMENTS:
        where = {"scene": [scene], "mujoco": [other], "holds": [scene, other]}[config.expert_plan_contact]
        each = [(s.config.object_contact, generate(obj, replace(params, placements=(p,)), scene=s))
                for s in where for p in params.placements]
        kept = choice.chosen(scene, [(w, t) for w, t in each if t.header["quality"]["passed"]], config)
    elif config.expert_plan_contact != "holds":
        kept = generate(obj, params, scene=other)
    else:
        own, soft = generate(obj, params, scene=scene), generate(obj, params, scene=other)
        held = [holds(scene, t, params.substeps, params.hold_steps) for t in (own, soft)]
        kept = soft if held[1] > held[0] else own
    return rested(scene, kept, config.grip_closure) if config.expert_rest else kept


def task_of(object_dir: str, trajectory: str | Trajectory | None, config: TaskConfig,
            scene_config: SceneConfig = SceneConfig(), slots: int | None = None) -> PullTask:
    """Object + trajectory (a file, a trajectory, or None: generated) -> the task, in ``scene_config`` (on the
    one-structure template of ``slots`` slots where given: ``scene.build_scene``)."""
    if not object_dir:
        raise DragMeshError("no object folder given (--object)")
    obj = load_gapartnet(object_dir)
    traj = read_trajectory(trajectory) if isinstance(trajectory, str) else trajectory
    if traj is not None:
        obj = adopt_trajectory_target(obj, traj)
    scene = build_scene(obj, scene_config, slots=slots)
    return PullTask(scene, traj if traj is not None else generated(obj, scene, config, slots), config)
