"""One policy over several objects (``train --objects``): the run record names each object with its content hash and
keeps each trajectory, checkpoints are chosen on the held-aside objects and a run resumes exactly. The policy
evaluated zero-shot on, and fine-tuned onto, an object folder it never saw: the README's commands
(tests/test_readme.py)."""

import dataclasses
import json

import jax
import numpy as np
import pytest

from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.evaluation.protocol import SELECTION
from dragmesh2_jax.io import object_hash
from dragmesh2_jax.runs.commands import load_run
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.runs.session import start_or_resume
from dragmesh2_jax.runs.spec import method_spec
from dragmesh2_jax.task.mix import ObjectMix
from tests.conftest import TINY_PPO, TINY_SIZES

pytestmark = pytest.mark.xdist_group(__name__)  # the module's run is trained once
OBJECTS = [str(packaged_object(n)) for n in ("drawer_cabinet_0000", "door_cabinet_0000", "drawer_cabinet_0213")]
QUIET = {"selection": dataclasses.replace(SELECTION, episodes=2), "progress": False}


def _spec(epochs: int):
    return method_spec("pica", OBJECTS, TINY_PPO, backend="mujoco", network=TINY_SIZES, holdout=1,
                       schedule={"epochs": epochs, "save_every": 1, "robust_every": 2})


@pytest.fixture(scope="session")
def mixed_run(tmp_path_factory):
    run = RunDir(tmp_path_factory.mktemp("mix") / "run")
    program, ts, _ = start_or_resume(_spec(2), [run], resume=False, **QUIET)
    return run, program, ts


def test_the_record_names_every_object_and_selection_uses_the_held_aside_one(mixed_run):
    run, program, _ = mixed_run
    record = json.loads(run.record_path.read_text())
    assert [o["hash"] for o in record["objects"]] == [object_hash(o) for o in OBJECTS] and record["holdout"] == 1
    assert len(set(o["hash"] for o in record["objects"])) == 3
    spec = run.spec()
    assert spec.training_objects == tuple(OBJECTS[:2]) and spec.heldout_objects == (OBJECTS[2],)
    assert isinstance(program.task, ObjectMix) and program.task.num_objects == 2
    assert [t.scene.obj.object_id for t in program.task.tasks] == ["drawer_cabinet_0000", "door_cabinet_0000"]
    trajectories = run.trajectories()  # one per object, the held-aside one included
    assert [t.header["object_id"] for t in trajectories] == [o.split("/")[-1] for o in OBJECTS]
    assert [r["epoch"] for r in run.robust_rows()] == [2] and run.policy_checkpoint().name == "best_robust"


def test_a_run_over_several_objects_resumes_exactly(mixed_run, tmp_path):
    run, _, _ = mixed_run
    cut = RunDir(tmp_path / "cut")
    start_or_resume(_spec(1), [cut], resume=False, **QUIET)
    _, resumed, _ = start_or_resume(_spec(2), [cut], resume=True, **QUIET)  # extended to the full run's epochs
    _, full, _, _ = load_run(run.checkpoint("final"))
    for x, y in zip(jax.tree.leaves(full.params), jax.tree.leaves(jax.tree.map(lambda v: v[0], resumed.params)),
                    strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
