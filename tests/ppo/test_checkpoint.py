"""Checkpoints: Orbax round trip, the learner alone, an earlier version's .npz, and a clear error on a mismatch."""

import io

import jax
import numpy as np
import pytest

from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.ppo.checkpoint import load_checkpoint, save_checkpoint
from dragmesh2_jax.runs import make_trainer

OBJ = str(default_object())


@pytest.fixture(scope="module")
def trainers():
    tiny = {"num_envs": 2, "rollout_len": 4, "update_epochs": 1}
    return (make_trainer(OBJ, None, "pica", "mujoco", **tiny),
            make_trainer(OBJ, None, "state_only", "mujoco", **tiny))


def _equal(a, b):
    for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def test_orbax_round_trip_learner_alone_and_replacement(trainers, tmp_path):
    pica, _ = trainers
    ts, _ = pica.epoch(pica.init(seed=1))
    save_checkpoint(pica.init(seed=2), tmp_path / "ck")
    save_checkpoint(ts, tmp_path / "ck")  # replaces the first, whole
    assert sorted(p.name for p in (tmp_path).iterdir()) == ["ck"]  # no temporary left behind
    _equal(load_checkpoint(pica.init(seed=3), tmp_path / "ck"), ts)
    fresh = pica.init(seed=3)
    learner = load_checkpoint(fresh, tmp_path / "ck", keep_env=True)
    _equal(learner.params, ts.params)  # the learner from the checkpoint, the worlds from the template
    _equal(learner.env_state, fresh.env_state)


def test_an_earlier_versions_npz_checkpoint_still_loads(trainers, tmp_path):
    pica, _ = trainers
    ts = pica.init(seed=4)
    buf = io.BytesIO()
    np.savez(buf, *[np.asarray(x) for x in jax.tree.leaves(ts)])
    (tmp_path / "final.npz").write_bytes(buf.getvalue())
    _equal(load_checkpoint(pica.init(seed=5), tmp_path / "final.npz"), ts)


def test_a_checkpoint_of_another_structure_is_a_clear_error(trainers, tmp_path):
    pica, state_only = trainers
    save_checkpoint(state_only.init(), tmp_path / "ck")
    with pytest.raises(DragMeshError, match="does not match this method/config"):
        load_checkpoint(pica.init(), tmp_path / "ck", keep_env=True)
    with pytest.raises(DragMeshError, match="no such checkpoint"):
        load_checkpoint(pica.init(), tmp_path / "missing")
