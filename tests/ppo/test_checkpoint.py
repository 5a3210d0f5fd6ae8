"""Checkpoints: a round trip, the learner alone, replacement that a kill cannot break, a storage fault as one OSError,
a clear error for a mismatched or damaged one, and checkpoints of earlier versions (Orbax) still loading."""

import contextlib
import dataclasses
import errno
import shutil
import subprocess
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import orbax.checkpoint as ocp
import pytest

from dragmesh2_jax import io
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.ppo.checkpoint import (
    ENV,
    LATER_FIELDS,
    LEARNER,
    _learner_fields,
    _sized_leaves,
    load_checkpoint,
    save_checkpoint,
)
from dragmesh2_jax.ppo.train import epoch_jit, init_jit
from tests.conftest import TINY_RUNS, fill, small_filesystem, tiny_program

pytestmark = pytest.mark.xdist_group(TINY_RUNS)  # its trained run is built once, beside the others


@pytest.fixture(scope="session")
def programs():
    return tiny_program("pica"), tiny_program("state_only")


def _init(p, seed):
    return init_jit(p, p.task.data, jax.random.PRNGKey(seed))


def _equal(a, b):
    for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def _legacy_save(ts, path, learner=None):
    """A checkpoint as versions before the msgpack files wrote it: two Orbax checkpoints."""
    ck = ocp.StandardCheckpointer()
    ck.save((path / "learner").absolute(), _learner_fields(ts) if learner is None else learner)
    ck.save((path / "env").absolute(), _sized_leaves(ts.env_state))
    ck.wait_until_finished()
    ck.close()


def test_round_trip_learner_alone_and_replacement(programs, tmp_path):
    pica, _ = programs
    ts, _ = epoch_jit(pica, pica.task.data, _init(pica, 1))
    save_checkpoint(_init(pica, 2), tmp_path / "ck")
    save_checkpoint(ts, tmp_path / "ck")  # replaces the first, whole
    assert sorted(p.name for p in (tmp_path).iterdir()) == ["ck"]  # no temporary left behind
    assert sorted(p.name for p in (tmp_path / "ck").iterdir()) == [ENV, LEARNER]
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
    saved = _init(pica, 0)
    save_checkpoint(saved, tmp_path / "pica")
    (tmp_path / "pica" / ENV).unlink()  # a checkpoint missing its worlds
    with pytest.raises(DragMeshError, match="cannot be read"):
        load_checkpoint(_init(pica, 1), tmp_path / "pica")
    template = _init(pica, 1)
    learner = load_checkpoint(template, tmp_path / "pica", keep_env=True)  # the learner still loads: the saved one,
    _equal(learner.replace(env_state=None), saved.replace(env_state=None))  # every field of it,
    _equal(learner.env_state, template.env_state)  # beside the template's worlds
    data = (tmp_path / "pica" / LEARNER).read_bytes()
    (tmp_path / "pica" / LEARNER).write_bytes(data[: len(data) // 2])  # truncated
    with pytest.raises(DragMeshError, match="damaged"):
        load_checkpoint(_init(pica, 1), tmp_path / "pica", keep_env=True)


def test_a_kill_during_a_replacement_leaves_a_whole_checkpoint(programs, tmp_path, monkeypatch):
    """Killed at any step of a replacement, the checkpoint loads, old or new: between two renames (where today's
    swap makes none), while the old copy is deleted; what a kill left beside it (an old copy half deleted) blocks no
    later save and is cleaned by ``restore_aside``. Without a way to swap two folders (not Linux), a kill between the
    two renames leaves the old one aside, and ``restore_aside`` puts it back."""
    pica, _ = programs
    old, new = _init(pica, 1), _init(pica, 2)
    path = tmp_path / "best"
    real_rename, real_rmtree = Path.rename, shutil.rmtree

    def second_rename_killed(self, target):
        renames.append(target)
        if len(renames) == 2:
            raise KeyboardInterrupt  # what a kill leaves: nothing after this step runs
        return real_rename(self, target)

    def old_copy_removal_killed(p, ignore_errors=False, **kwargs):
        if ignore_errors:  # clearing what an earlier kill left: let through
            return real_rmtree(p, ignore_errors=True, **kwargs)
        raise KeyboardInterrupt

    for patch, after in ((("rename", second_rename_killed), new), (("rmtree", old_copy_removal_killed), new)):
        renames = []
        save_checkpoint(old, path)
        monkeypatch.setattr(Path if patch[0] == "rename" else shutil, *patch)
        with pytest.raises(KeyboardInterrupt) if patch[0] == "rmtree" else contextlib.nullcontext():
            save_checkpoint(new, path)
        monkeypatch.undo()
        _equal(load_checkpoint(_init(pica, 3), path).rng, after.rng)
    real_rmtree(io.beside(path), ignore_errors=True)
    shutil.copytree(path, io.aside(path))  # an old copy an earlier version left half deleted
    save_checkpoint(old, path)  # is no obstacle
    _equal(load_checkpoint(_init(pica, 3), path).rng, old.rng)
    assert io.restore_aside(tmp_path) == [] and sorted(p.name for p in tmp_path.iterdir()) == ["best"]

    monkeypatch.setattr(io, "_exchange", lambda a, b: False)
    renames = []
    monkeypatch.setattr(Path, "rename", second_rename_killed)
    with pytest.raises(KeyboardInterrupt):
        save_checkpoint(new, path)
    monkeypatch.setattr(Path, "rename", real_rename)
    assert not path.exists() and io.aside(path).is_dir()
    assert io.restore_aside(tmp_path) == [f"{path}: restored (a kill interrupted its replacement)",
                                          f"{io.beside(path)}: removed (a replacement a kill left unfinished)"]
    _equal(load_checkpoint(_init(pica, 3), path).rng, old.rng)


def test_a_full_disk_is_one_os_error_and_leaves_the_checkpoint_as_it_was(programs, tmp_path):
    """On a real filesystem with room for half a checkpoint: ENOSPC raised once, no temporary left, the checkpoint
    there before intact."""
    pica, _ = programs
    ts = _init(pica, 1)
    save_checkpoint(ts, tmp_path / "ck")
    size = sum(p.stat().st_size for p in (tmp_path / "ck").iterdir())
    with small_filesystem(tmp_path / "small") as small:
        shutil.copytree(tmp_path / "ck", small / "best")
        fill(small, size // 2)
        with pytest.raises(OSError) as e:
            save_checkpoint(_init(pica, 2), small / "best")
        assert e.value.errno == errno.ENOSPC
        assert sorted(p.name for p in small.iterdir()) == ["best", "filler"]
        _equal(load_checkpoint(_init(pica, 3), small / "best").rng, ts.rng)


def test_checkpoints_written_by_earlier_versions_load(programs, tmp_path):
    """Two Orbax checkpoints, as versions before the msgpack files wrote them: the whole state, or the learner."""
    pica, _ = programs
    ts, _ = epoch_jit(pica, pica.task.data, _init(pica, 1))
    _legacy_save(ts, tmp_path / "ck")
    _equal(load_checkpoint(_init(pica, 2), tmp_path / "ck"), ts)
    _equal(load_checkpoint(_init(pica, 2), tmp_path / "ck", keep_env=True).params, ts.params)
    save_checkpoint(ts, tmp_path / "ck")  # replaced by this version's
    _equal(load_checkpoint(_init(pica, 2), tmp_path / "ck"), ts)


def test_a_checkpoint_from_before_the_constraints_restores_with_their_multipliers_at_zero(programs, tmp_path):
    """Written before the multipliers were a vector: without them (a run with no constraint) or with the single
    load constraint's scalar ``load_lambda`` in their place."""
    pica, _ = programs
    ts = _init(pica, 1)
    for k, retired in enumerate(({}, {"load_lambda": jnp.float32(3.0)})):
        learner = ts.replace(env_state=None)  # the learner as a run before the multipliers existed wrote it:
        learner = {f.name: getattr(learner, f.name) for f in dataclasses.fields(learner)
                   if f.name not in LATER_FIELDS and f.name != "env_state"}
        _legacy_save(ts, tmp_path / f"ck{k}", learner | retired)
        old = load_checkpoint(_init(pica, 2), tmp_path / f"ck{k}")
        assert old.multipliers.shape == (0,)
        _equal(old, ts)


def test_a_process_killed_while_saving_leaves_a_checkpoint_that_loads(programs, tmp_path):
    """SIGKILL at moments spread over a loop of saves (a real kill: no Python cleanup runs): the checkpoint is
    there and loads, whole, after each."""
    pica, _ = programs
    path = tmp_path / "best"
    save_checkpoint(_init(pica, 0), path)
    script = (f"import jax, sys; sys.path.insert(0, {str(Path(__file__).parents[2])!r})\n"
              "from tests.conftest import tiny_program\n"
              "from dragmesh2_jax.ppo.checkpoint import save_checkpoint\n"
              "from dragmesh2_jax.ppo.train import init_jit\n"
              "p = tiny_program('pica'); ts = init_jit(p, p.task.data, jax.random.PRNGKey(0))\n"
              f"print('ready', flush=True)\nwhile True: save_checkpoint(ts, {str(path)!r})\n")
    for delay in (0.05, 0.2, 0.45):
        proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
        assert proc.stdout.readline().strip() == "ready"
        try:
            proc.wait(timeout=delay)
        except subprocess.TimeoutExpired:
            proc.kill()
        proc.wait()
        io.restore_aside(tmp_path)
        _equal(load_checkpoint(_init(pica, 1), path).rng, _init(pica, 0).rng)
