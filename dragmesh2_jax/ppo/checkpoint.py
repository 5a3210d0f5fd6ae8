"""Checkpoints: a training state as files, written whole or not at all.

A checkpoint is a directory of two files: ``learner.msgpack`` (parameters, optimiser, normalisers, rng, epoch, the
reward's adaptive weights: the TrainState without its worlds) and ``env.msgpack`` (the worlds' states), so that exact
resume restores both and evaluation or a fine-tune can restore the learner alone, even from a run whose environment
state had another layout. They are written synchronously (flax's msgpack, as the exported actor), so a storage fault
such as a full disk is one ``OSError`` raised here, with no writer thread left to report it again, and no callback
outlives the call. The directory is written beside its place and takes it in one step (``io.replace_folder``): a kill
at any moment leaves the old checkpoint or the new one, whole (``best``/``best_robust`` included). A checkpoint that
does not match the program (another method, config or version), or a damaged one, is one clear error, not a crash.
Checkpoints written by earlier versions (two Orbax checkpoints, ``learner/`` and ``env/``) still load. Where
checkpoints live in a run folder is ``runs/rundir.py``'s business.

An exported actor (``*.msgpack``, :func:`save_actor`) is what a policy reads and nothing else: the network's actor
parameters and the observation normalisers, a few MB where a checkpoint holds the critic, the optimiser and the
worlds too. It loads into a fresh state (critic and optimiser new): for evaluation, or a fine-tune that trains a
critic again."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import orbax.checkpoint as ocp
from flax import serialization

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.io import atomic_write_bytes, beside, replace_folder
from dragmesh2_jax.ppo.train import TrainState


def save_checkpoint(ts: TrainState, path: str | Path) -> Path:
    """Write ``ts`` as the checkpoint directory ``path``, replacing one that is there in one step."""
    path = Path(path).absolute()
    tmp = beside(path)
    shutil.rmtree(tmp, ignore_errors=True)  # an unfinished write a kill left
    try:
        atomic_write_bytes(tmp / LEARNER, _pack({f: getattr(ts, f) for f in _LEARNER}))
        atomic_write_bytes(tmp / ENV, _pack(_leaves(ts.env_state)))
    except BaseException:  # a full disk, an interrupt: the old checkpoint stands, nothing half-written beside it
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    replace_folder(tmp, path)
    return path


#: The files of a checkpoint directory; ``LEGACY``: the first of the two Orbax checkpoints earlier versions wrote.
LEARNER, ENV, LEGACY = "learner.msgpack", "env.msgpack", "learner"
#: The TrainState's fields the learner file holds: all but the worlds.
_LEARNER = tuple(f.name for f in dataclasses.fields(TrainState) if f.name != "env_state")


def _pack(tree) -> bytes:
    return serialization.msgpack_serialize(serialization.to_state_dict(jax.device_get(tree)))


def _beyond(want, got, at: str = "") -> str | None:
    """The first key of the stored state dict ``got`` that ``want`` (the program's) lacks: flax restores a template's
    keys and drops the rest, so a record whose network lost a layer would load the checkpoint's first layers alone."""
    if not (isinstance(want, dict) and isinstance(got, dict)):
        return None
    for k, v in got.items():
        if k not in want:
            return f"{at}/{k}"
        if extra := _beyond(want[k], v, f"{at}/{k}"):
            return extra
    return None


def _unpack(template, data: bytes):
    """``template``'s structure with the values of ``data``; another structure or another shape is a ValueError."""
    state = serialization.msgpack_restore(data)
    if extra := _beyond(serialization.to_state_dict(template), state):
        raise ValueError(f"the checkpoint holds {extra}, which the program does not")
    tree = serialization.from_state_dict(template, state)
    for want, got in zip(jax.tree.leaves(template), jax.tree.leaves(tree), strict=True):
        if np.shape(want) != np.shape(got):
            raise ValueError(f"an array of shape {np.shape(got)} where the program has {np.shape(want)}")
    return tree


def _leaves(env_state) -> dict:
    """The worlds' state by position of its leaves (its structure is the program's, rebuilt from the template)."""
    return {_key(i): x for i, x in enumerate(jax.tree.leaves(env_state))}


#: TrainState fields added after (Orbax) checkpoints were first written: a checkpoint without one restores with the
#: template's value (the constraints' multipliers at 0: a run before them had none, and one of the single load
#: constraint, whose scalar multiplier is not read, starts its multiplier again from 0 on resume; an object mix's
#: success rates, which only its curriculum keeps).
LATER_FIELDS = frozenset({"multipliers", "object_success"})


def _learner_fields(ts: TrainState) -> dict:
    """The learner (the TrainState without its worlds) by field, as earlier versions wrote it for Orbax: without the
    empty ones Orbax refuses (the multipliers of a reward with no constraint), which restore as the template's."""
    return {f.name: getattr(ts, f.name) for f in dataclasses.fields(ts)
            if f.name != "env_state" and not _empty(getattr(ts, f.name))}


def _empty(x) -> bool:
    return getattr(x, "size", None) == 0


def _restore_learner(ck: ocp.StandardCheckpointer, path: Path, learner: TrainState) -> TrainState:
    stored = ck.metadata(path).item_metadata.tree
    fields = _learner_fields(learner)
    held = {k: v for k, v in fields.items() if k in stored or k not in LATER_FIELDS}
    # what the checkpoint holds beyond the learner's fields is read and dropped: the empty worlds of checkpoints
    # written as a whole TrainState, the single load constraint's scalar multiplier
    extra = {k: None if m is None else jax.ShapeDtypeStruct(m.shape, m.dtype) for k, m in stored.items()
             if k not in fields}
    restored = ck.restore(path, held | extra)
    return learner.replace(**{k: v for k, v in restored.items() if k in fields})


def _key(i: int) -> str:
    return f"leaf_{i:05d}"


def _sized_leaves(env_state) -> dict:
    """The worlds' state as earlier versions wrote it for Orbax: its leaves by position, without the empty ones (an
    engine state has arrays of size 0, e.g. MJX's activations when no actuator has one, which Orbax refuses)."""
    return {_key(i): x for i, x in enumerate(jax.tree.leaves(env_state)) if x.size}


#: The network's modules a policy reads (``ActorCritic.actor``): the state MLP, the temporal encoder, the mean head
#: and the log std; and the normalisers of what it observes.
ACTOR_MODULES = ("state_mlp", "temporal", "mu", "log_std")
ACTOR_SUFFIX = ".msgpack"


def _actor(ts: TrainState) -> dict:
    net = ts.params["params"]
    return {"params": {k: net[k] for k in ACTOR_MODULES if k in net}, "state_stats": ts.state_stats,
            "token_stats": ts.token_stats, "epoch": ts.epoch}


def save_actor(ts: TrainState, path: str | Path) -> Path:
    """Write the policy of ``ts`` (one run's state) as an exported actor at ``path`` (``*.msgpack``)."""
    return atomic_write_bytes(path, serialization.msgpack_serialize(serialization.to_state_dict(
        jax.device_get(_actor(ts)))))


def load_actor(template: TrainState, path: str | Path) -> TrainState:
    """``template`` with the policy of the exported actor at ``path``; one that another network wrote is one error
    line."""
    try:
        actor = _unpack(_actor(template), Path(path).read_bytes())
    except (ValueError, KeyError, TypeError) as e:
        raise DragMeshError(f"{path}: the exported actor does not match this method/config ({e})") from None
    params = {**template.params, "params": {**template.params["params"], **actor["params"]}}
    return _uncommitted(template.replace(params=params, state_stats=actor["state_stats"],
                                         token_stats=actor["token_stats"], epoch=actor["epoch"]))


def is_checkpoint(path: str | Path) -> bool:
    """A checkpoint directory (of this version or an earlier one), or an exported actor."""
    path = Path(path)
    return ((path / LEARNER).is_file() or (path / LEGACY).is_dir()
            or (path.suffix == ACTOR_SUFFIX and path.is_file()))


def load_checkpoint(template: TrainState, path: str | Path, keep_env: bool = False) -> TrainState:
    """Restore ``template``'s structure from the checkpoint at ``path``. With ``keep_env`` the environment state is
    the template's and only the learner is read: a policy still loads for evaluation or a fine-tune when the
    environment state's layout changed (not for exact resume)."""
    path = Path(path)
    if not is_checkpoint(path):
        raise DragMeshError(f"{path}: no such checkpoint")
    if path.suffix == ACTOR_SUFFIX:
        return load_actor(template, path)
    try:
        ts = (_load if (path / LEARNER).is_file() else _load_orbax)(template, path, keep_env)
    except OSError as e:
        raise DragMeshError(f"{e.filename or path}: cannot be read ({e.strerror})") from None
    except Exception as e:  # msgpack, flax and (earlier versions') orbax raise many types for a damaged file
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise DragMeshError(f"{path}: checkpoint does not match this method/config or is damaged "
                            f"({first[:200]})") from None
    return _uncommitted(ts)


def _load(template: TrainState, path: Path, keep_env: bool) -> TrainState:
    learner = _unpack({f: getattr(template, f) for f in _LEARNER}, (path / LEARNER).read_bytes())
    env = template.env_state
    if not keep_env:
        stored = _unpack(_leaves(env), (path / ENV).read_bytes())
        env = jax.tree.unflatten(jax.tree.structure(env), [stored[_key(i)] for i in range(len(stored))])
    return template.replace(env_state=env, **learner)


def _load_orbax(template: TrainState, path: Path, keep_env: bool) -> TrainState:
    """A checkpoint an earlier version wrote: two Orbax checkpoints."""
    ck = ocp.StandardCheckpointer()
    try:
        ts = _restore_learner(ck, (path / LEGACY).absolute(), template.replace(env_state=None))
        env = template.env_state
        if not keep_env:
            restored = ck.restore((path / "env").absolute(), _sized_leaves(env))
            leaves, treedef = jax.tree.flatten(env)
            env = jax.tree.unflatten(treedef, [restored.get(_key(i), x) for i, x in enumerate(leaves)])
    finally:
        ck.close()
    return ts.replace(env_state=env)


def _uncommitted(tree):
    """``tree``'s arrays as a fresh run's are: restored ones may be committed to a device, and a jitted program
    called with committed arrays where it was called with uncommitted ones compiles again (a resume in the same
    process, a notebook, reproduce)."""
    return jax.tree.map(lambda x: jnp.asarray(np.asarray(x)) if isinstance(x, jax.Array) else x, tree)
