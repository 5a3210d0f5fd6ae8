"""Checkpoints with Orbax (as Brax and Playground).

A checkpoint is a directory of two Orbax checkpoints: ``learner`` (parameters, optimiser, normalisers, rng, epoch,
the ARAM weight: the TrainState without its worlds) and ``env`` (the worlds' states), so that exact resume restores
both and evaluation or a fine-tune can restore the learner alone, even from a run whose environment state had
another layout. It is written to a temporary sibling and renamed into place (a crash never leaves half a
checkpoint, and ``best``/``best_robust`` are replaced whole). A checkpoint that does not match the program (another
method, config or version), or a damaged one, is one clear error, not a crash. Where checkpoints live in a run
folder is ``runs/rundir.py``'s business.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import orbax.checkpoint as ocp

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.ppo.train import TrainState


def save_checkpoint(ts: TrainState, path: str | Path) -> Path:
    """Write ``ts`` as the checkpoint directory ``path`` (replacing one that is there)."""
    path = Path(path).absolute()
    tmp = path.with_name(f".{path.name}.tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    ck = ocp.StandardCheckpointer()
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


def is_checkpoint(path: str | Path) -> bool:
    return (Path(path) / "learner").is_dir()


def load_checkpoint(template: TrainState, path: str | Path, keep_env: bool = False) -> TrainState:
    """Restore ``template``'s structure from the checkpoint at ``path``. With ``keep_env`` the environment state is
    the template's and only the learner is read: a policy still loads for evaluation or a fine-tune when the
    environment state's layout changed (not for exact resume)."""
    path = Path(path)
    if not is_checkpoint(path):
        raise DragMeshError(f"{path}: no such checkpoint")
    ck = ocp.StandardCheckpointer()
    try:
        ts = ck.restore((path / "learner").absolute(), template.replace(env_state=None))
        env = template.env_state if keep_env else ck.restore((path / "env").absolute(), template.env_state)
    except Exception as e:  # orbax and tensorstore raise many types for a damaged or mismatched checkpoint
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise DragMeshError(f"{path}: checkpoint does not match this method/config or is damaged "
                            f"({first[:200]})") from None
    finally:
        ck.close()
    return ts.replace(env_state=env)
