"""A distilled run's teachers (``RunSpec.teachers``, ``PPOConfig.distill_coef``): per-object specialists, each a run
on one of the student's training objects, whose policies label the student's steps (``ppo/distill.py``).

A teacher labels a world only if its action means there what the student's does: it must have been trained with the
student's network, scene and task (the engine, the buffer sizes and the object draw aside) on the same object (by
content: the folder may be a copy) and the same expert drag (a residual's action adds to it). Each is read at the
checkpoint that stands for its run. Objects without a teacher are not labelled; a held-aside object never is.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import jax.numpy as jnp

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.io import object_hash
from dragmesh2_jax.ppo.checkpoint import load_checkpoint
from dragmesh2_jax.ppo.distill import Teachers
from dragmesh2_jax.ppo.train import TrainState, policy_params
from dragmesh2_jax.runs.rundir import RunDir, epoch_name
from dragmesh2_jax.runs.spec import RunSpec
from dragmesh2_jax.task.config import RESIZABLE
from dragmesh2_jax.trajectory.schema import Trajectory

#: TaskConfig fields a teacher may have trained with otherwise than its student: how a run is computed (the engine,
#: the buffers) and how a mix draws its objects, not what a world's episode is.
FREE = ("backend", "impl", "object_curriculum", *RESIZABLE)


def _task(spec: RunSpec, like: RunSpec):
    return dataclasses.replace(spec.task, **{k: getattr(like.task, k) for k in FREE})


def _paired(teachers, distill_coef: float) -> None:
    """Teachers go with a label loss (``distill_coef`` > 0), and a label loss with teachers."""
    if bool(teachers) != (distill_coef > 0):
        raise DragMeshError("a distilled run (ppo.distill_coef > 0) names its teachers (--teachers RUN ...), and "
                            "teachers label only a distilled run")


def named_teachers(teachers: list[str] | tuple[str, ...], distill_coef: float) -> tuple[str, ...]:
    """The teachers a command names, each pinned to the checkpoint that stands for it now (its last epoch's where
    that is ``final``: a teacher trained on later still labels a resumed student as it did), checked before anything
    is built or written (``_paired``)."""
    _paired(teachers, distill_coef)
    pinned = []
    for folder in teachers:
        run, checkpoint = RunDir.of_checkpoint(folder)
        if checkpoint == run.checkpoint("final") and run.has_checkpoint(last := epoch_name(run.trained_epochs())):
            checkpoint = run.checkpoint(last)
        pinned.append(str(checkpoint.resolve()))
    return tuple(pinned)


def teacher_runs(spec: RunSpec) -> list[tuple[int, RunDir, Path]]:
    """The teachers of ``spec`` (none for a run that does not distil), each as (its object's index among the training
    objects, its run, the checkpoint that stands for it), checked from the records alone: anything that keeps a
    teacher from labelling is one error line (the expert drag is checked on loading, where it is built)."""
    _paired(spec.teachers, spec.ppo.distill_coef)
    training = [object_hash(o) for o in spec.training_objects]
    held = {object_hash(o) for o in spec.heldout_objects}
    found: list[tuple[int, RunDir, Path]] = []
    for folder in spec.teachers:
        run, checkpoint = RunDir.of_checkpoint(folder)
        taught = run.spec()
        if taught.objects:
            raise DragMeshError(f"{run.path}: a teacher is a specialist, a run on one object (this one trained on "
                                f"{len(taught.objects)})")
        h = object_hash(taught.object)
        if h in held:
            raise DragMeshError(f"{run.path}: its object is held aside from the student's training: not taught")
        if h not in training:
            raise DragMeshError(f"{run.path}: its object ({taught.object}) is none of the student's training objects")
        i = training.index(h)
        if any(j == i for j, _, _ in found):
            raise DragMeshError(f"{run.path}: a second teacher for {spec.training_objects[i]}")
        differ = [g for g in ("network", "scene") if getattr(taught, g) != getattr(spec, g)]
        differ += ["observation normalisation"] if taught.ppo.normalize_obs != spec.ppo.normalize_obs else []
        differ += ["task"] if _task(taught, spec) != spec.task else []
        if differ:
            raise DragMeshError(f"{run.path}: trained with another {', '.join(differ)} than the student's: its "
                                "actions mean something else there (train it with the student's method)")
        found.append((i, run, checkpoint))
    return found


def load_teachers(spec: RunSpec, trajectories: list[Trajectory], template: TrainState) -> Teachers | None:
    """The teachers of ``spec`` (``teacher_runs``; None for a run that does not distil), in the order of its training
    objects, None where an object has none; ``trajectories``: the student's expert drag on each training object (a
    teacher's must be the same); ``template``: one run's state of the student's program (each teacher's policy is
    read into it)."""
    found = teacher_runs(spec)
    if not found:
        return None
    params: list[dict | None] = [None] * len(trajectories)
    for i, run, checkpoint in found:
        if run.trajectory().frames != trajectories[i].frames:
            raise DragMeshError(f"{run.path}: trained on another expert drag than the student's on its object (a "
                                "residual adds to it): train it with the student's method and trajectory")
        # a specialist has no object draw to restore (a curriculum student's template has one)
        params[i] = policy_params(load_checkpoint(template.replace(object_success=jnp.zeros(0, jnp.float32)),
                                                  checkpoint, keep_env=True))
    return Teachers.stack(params)
