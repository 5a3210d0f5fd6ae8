"""A distilled run's teachers (``runs/teachers.py``): a specialist on one of the student's objects labels that object's
worlds, found by the object's content; the record keeps the teachers and a resume reads them back; a teacher whose
actions would mean something else, or a distilled run without teachers, is one error line before any folder is
written."""

import dataclasses
import shutil

import numpy as np
import pytest

from dragmesh2_jax.assets.procedural import default_object, packaged_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.runs.session import start_or_resume
from dragmesh2_jax.runs.spec import finetune_spec, on_objects
from tests.conftest import TINY_RUNS, tiny_spec

pytestmark = pytest.mark.xdist_group(TINY_RUNS)

DRAWER, DOOR = str(default_object()), str(packaged_object("door_cabinet_0000"))
QUICK = {"robust_every": 0}


@pytest.fixture(scope="module")
def teacher(tmp_path_factory):
    """A specialist on a copy of the packaged drawer (the student names the original folder)."""
    root = tmp_path_factory.mktemp("teachers")
    copy = shutil.copytree(DRAWER, root / "drawer_copy")
    run = RunDir(root / "drawer")
    start_or_resume(tiny_spec(obj=str(copy), schedule=QUICK), [run], resume=False, progress=False)
    return run


def _student(teachers, objects=(DRAWER, DOOR), holdout: int = 0, task: dict | None = None, **ppo):
    """A tiny distilled run over ``objects``, 8 worlds (drawn over both objects)."""
    spec = on_objects(tiny_spec(schedule=QUICK, **{"distill_coef": 1.0, "num_envs": 8, **ppo}), list(objects), holdout)
    return dataclasses.replace(spec, teachers=tuple(str(t) for t in teachers),
                               task=dataclasses.replace(spec.task, **(task or {})))


def test_the_specialist_labels_its_objects_worlds_and_a_resume_keeps_it(teacher, tmp_path):
    run = RunDir(tmp_path / "student")
    _, _, (rows,) = start_or_resume(_student([teacher.path]), [run], resume=False, progress=False)
    taught = [r["taught"] for r in rows]
    assert all(0 < t < 1 for t in taught)  # the drawer's worlds are labelled, the door's not
    assert all(np.isfinite(r["distill_loss"]) and r["distill_loss"] > 0 for r in rows)
    assert [r["w_distill"] for r in rows] == [1.0, 1.0]
    assert run.record()["teachers"] == [str(teacher.path.resolve())]
    resumed = dataclasses.replace(run.spec(), schedule=dataclasses.replace(run.spec().schedule, epochs=3))
    _, _, (rows,) = start_or_resume(resumed, [run], resume=True, progress=False)
    assert len(rows) == 3 and rows[-1]["taught"] > 0
    # a fine-tune of the student is PPO on its own: no teachers, no label loss
    tuned = finetune_spec(run.spec(), "continued", str(run.checkpoint("final")), 4)
    assert tuned.teachers == () and tuned.ppo.distill_coef == 0 and tuned.ppo.distill_epochs == 0


def test_a_student_that_draws_its_objects_by_their_failures_is_taught_too(teacher, tmp_path):
    """The object curriculum keeps a success rate per object in the student's state; a specialist has none."""
    run = RunDir(tmp_path / "student")
    _, _, (rows,) = start_or_resume(_student([teacher.path], task={"object_curriculum": 0.5}), [run], resume=False,
                                    progress=False)
    assert all(r["taught"] > 0 for r in rows)


@pytest.mark.parametrize("case, match", [
    ("no teachers", "names its teachers"),
    ("no label loss", "names its teachers"),
    ("another network", "another network"),
    ("another task", "another task"),
    ("held aside", "held aside"),
    ("not an object of the student's", "none of the student's training objects"),
    ("twice", "a second teacher"),
])
def test_a_teacher_that_cannot_label_is_refused_before_a_folder_is_written(teacher, tmp_path, case, match):
    spec = {
        "no teachers": _student([]),
        "no label loss": _student([teacher.path], distill_coef=0.0),
        "another network": dataclasses.replace(_student([teacher.path]), network=dataclasses.replace(
            _student([]).network, state_sizes=(32, 32))),
        "another task": dataclasses.replace(_student([teacher.path]), task=dataclasses.replace(
            _student([]).task, alpha=0.04)),
        "held aside": _student([teacher.path], objects=(DOOR, DRAWER), holdout=1),
        "not an object of the student's": _student([teacher.path], objects=(DOOR, str(packaged_object(
            "dishwasher_0000")))),
        "twice": _student([teacher.path, teacher.path]),
    }[case]
    run = RunDir(tmp_path / "student")
    with pytest.raises(DragMeshError, match=match):
        start_or_resume(spec, [run], resume=False, progress=False)
    assert not run.exists()
