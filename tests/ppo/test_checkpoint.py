"""Checkpoints: Orbax round trip, the learner alone, and a clear error for a mismatched or damaged one."""

import dataclasses
import shutil

import jax
import jax.numpy as jnp
import numpy as np
import orbax.checkpoint as ocp
import pytest

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.ppo.checkpoint import LATER_FIELDS, load_checkpoint, save_checkpoint
from dragmesh2_jax.ppo.train import epoch_jit, init_jit
from tests.conftest import TINY_RUNS, tiny_program

pytestmark = pytest.mark.xdist_group(TINY_RUNS)  # its trained run is built once, beside the others


@pytest.fixture(scope="session")
def programs():
    return tiny_program("pica"), tiny_program("state_only")


def _init(p, seed):
    return init_jit(p, p.task.data, jax.random.PRNGKey(seed))


def _equal(a, b):
    for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def test_orbax_round_trip_learner_alone_and_replacement(programs, tmp_path):
    pica, _ = programs
    ts, _ = epoch_jit(pica, pica.task.data, _init(pica, 1))
    save_checkpoint(_init(pica, 2), tmp_path / "ck")
    save_checkpoint(ts, tmp_path / "ck")  # replaces the first, whole
    assert sorted(p.name for p in (tmp_path).iterdir()) == ["ck"]  # no temporary left behind
    _equal(load_checkpoint(_init(pica, 3), tmp_path / "ck"), ts)
    fresh = _init(pica, 3)
    learner = load_checkpoint(fresh, tmp_path / "ck", keep_env=True)
    _equal(learner.params, ts.params)  # the learner from the checkpoint, the worlds from the template
    _equal(learner.env_state, fresh.env_state)


def test_a_checkpoint_of_another_structure_or_a_damaged_one_is_a_clear_error(programs, tmp_path):
    pica, state_only = programs
    save_checkpoint(_init(state_only, 0), tmp_path / "ck")
    with pytest.raises(DragMeshError, match="does not match this method/config"):
        load_checkpoint(_init(pica, 0), tmp_path / "ck", keep_env=True)
    with pytest.raises(DragMeshError, match="no such checkpoint"):
        load_checkpoint(_init(pica, 0), tmp_path / "missing")
    save_checkpoint(_init(pica, 0), tmp_path / "pica")
    shutil.rmtree(tmp_path / "pica" / "env")  # a checkpoint missing an item
    with pytest.raises(DragMeshError, match="damaged"):
        load_checkpoint(_init(pica, 0), tmp_path / "pica")
    assert load_checkpoint(_init(pica, 0), tmp_path / "pica", keep_env=True) is not None  # the learner still loads


def test_a_checkpoint_from_before_the_constraints_restores_with_their_multipliers_at_zero(programs, tmp_path):
    """Written before the multipliers were a vector: without them (a run with no constraint) or with the single
    load constraint's scalar ``load_lambda`` in their place."""
    pica, _ = programs
    ts = _init(pica, 1)
    for retired in ({}, {"load_lambda": jnp.float32(3.0)}):
        save_checkpoint(ts, tmp_path / "ck")
        learner = ts.replace(env_state=None)  # the learner as a run before the multipliers existed wrote it:
        learner = {f.name: getattr(learner, f.name) for f in dataclasses.fields(learner)
                   if f.name not in LATER_FIELDS}
        shutil.rmtree(tmp_path / "ck" / "learner")
        ck = ocp.StandardCheckpointer()
        ck.save((tmp_path / "ck" / "learner").absolute(), learner | retired)
        ck.wait_until_finished()
        ck.close()
        old = load_checkpoint(_init(pica, 2), tmp_path / "ck")
        assert old.multipliers.shape == (0,)
        _equal(old, ts)
