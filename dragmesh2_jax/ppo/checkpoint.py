"""Checkpoints with Orbax (as Brax and Playground), inside a run folder beside its record (``run.json``).

A checkpoint is a directory of two Orbax checkpoints: ``learner`` (parameters, optimiser, normalisers, rng,
epoch: the TrainState without its worlds) and ``env`` (the worlds' states), so that exact resume restores both
and evaluation or a fine-tune can restore the learner alone, even from a run whose environment state had another
layout. It is written to a temporary sibling and renamed into place (a crash never leaves half a checkpoint, and
``best``/``best_robust`` are replaced whole). Checkpoints of earlier versions (single ``.npz`` files of every
leaf) still load. A checkpoint that does not match the trainer (another method, config or version) is one clear
error, not a crash.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import jax
import numpy as np

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.ppo.train import TrainState

LEGACY_SUFFIX = ".npz"


def _checkpointer():
    import orbax.checkpoint as ocp

    return ocp.StandardCheckpointer()


def save_checkpoint(ts: TrainState, path: str | Path) -> Path:
    """Write ``ts`` as the checkpoint directory ``path`` (replacing one that is there)."""
    path = Path(path).absolute()
    tmp = path.with_name(f".{path.name}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    ck = _checkpointer()
    try:
        ck.save(tmp / "learner", ts.replace(env_state=None))
        ck.save(tmp / "env", ts.env_state)
        ck.wait_until_finished()
    finally:
        ck.close()
    old = path.with_name(f".{path.name}.old")
    if path.exists():
        path.rename(old)
    tmp.rename(path)
    shutil.rmtree(old, ignore_errors=True)
    return path


def load_checkpoint(template: TrainState, path: str | Path, keep_env: bool = False) -> TrainState:
    """Restore ``template``'s structure from the checkpoint at ``path``. With ``keep_env`` the environment state is
    the template's and only the learner is read: a policy still loads for evaluation or a fine-tune when the
    environment state's layout changed (not for exact resume)."""
    path = Path(path)
    if path.suffix == LEGACY_SUFFIX:
        return _load_legacy(template, path, keep_env)
    if not (path / "learner").is_dir():
        raise DragMeshError(f"{path}: no such checkpoint")
    ck = _checkpointer()
    try:
        ts = ck.restore((path / "learner").absolute(), template.replace(env_state=None))
        env = template.env_state if keep_env else ck.restore((path / "env").absolute(), template.env_state)
    except (ValueError, KeyError, TypeError, FileNotFoundError) as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise DragMeshError(f"{path}: checkpoint does not match this method/config ({first[:200]})") from None
    finally:
        ck.close()
    return ts.replace(env_state=env)


def _load_legacy(template: TrainState, path: Path, keep_env: bool) -> TrainState:
    """A ``.npz`` checkpoint of an earlier version: every leaf of the TrainState, in order."""
    if not path.is_file():
        raise DragMeshError(f"{path}: no such checkpoint")
    z = np.load(path)
    leaves, treedef = jax.tree.flatten(template)
    index = list(range(len(leaves)))
    if keep_env and len(z.files) != len(leaves):
        n_before = len(jax.tree.leaves((template.params, template.opt_state)))
        n_env = len(jax.tree.leaves(template.env_state))
        n_after = len(leaves) - n_before - n_env
        if len(z.files) > n_before + n_after:
            # (file array, or None = keep the template's leaf) per template leaf
            index = [*range(n_before), *([None] * n_env), *range(len(z.files) - n_after, len(z.files))]
    if len(index) != len(leaves) or (not keep_env and len(z.files) != len(leaves)):
        raise DragMeshError(f"{path}: checkpoint does not match this method/config ({len(z.files)} arrays, "
                            f"expected {len(leaves)})")
    new = []
    for i, ref in zip(index, leaves, strict=True):
        if i is None:
            new.append(ref)
            continue
        a = z[f"arr_{i}"]
        if a.shape != np.shape(ref):
            raise DragMeshError(f"{path}: array {i} has shape {a.shape}, expected {np.shape(ref)}")
        new.append(jax.numpy.asarray(a, dtype=np.asarray(ref).dtype))
    return jax.tree.unflatten(treedef, new)


def checkpoint_epoch(path: Path) -> int | None:
    """The epoch of an ``epoch_NNNN`` checkpoint (directory, or legacy file), else None."""
    stem = path.name.removesuffix(LEGACY_SUFFIX)
    if not stem.startswith("epoch_") or not stem[6:].isdigit():
        return None
    return int(stem[6:])


def find_checkpoint(run_dir: Path, name: str) -> Path | None:
    """``checkpoints/NAME`` of a run folder: the Orbax directory, else an earlier version's ``NAME.npz``."""
    for p in (run_dir / "checkpoints" / name, run_dir / "checkpoints" / f"{name}{LEGACY_SUFFIX}"):
        if p.is_dir() or p.is_file():
            return p
    return None
