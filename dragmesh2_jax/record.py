"""The run record (``run.json``): everything that defines a run, written once when it starts and read back whole.

    format        RECORD_FORMAT
    method        the preset's name (its fields are in ``task`` and ``ppo`` already)
    finetune, parent   a fine-tune's recipe and the checkpoint it continued (fine-tunes only)
    object        the object folder; ``trajectory``: the trajectory file copied into the run folder
    backend       the engine it trained on
    ppo, task, scene   the whole PPOConfig, TaskConfig and SceneConfig (nested dataclasses as JSON)
    versions      dragmesh2-jax, jax, jaxlib, mujoco, python

``config_from_dict`` turns a recorded config back into its frozen dataclass (tuples, optional and nested
configs included), so evaluation, ``--resume`` and fine-tunes rebuild the task and scene the run trained on,
not the defaults.
"""

from __future__ import annotations

import dataclasses
import json
import platform
import types
import typing
from importlib import metadata
from typing import Any

from dragmesh2_jax.errors import DragMeshError

RECORD_FORMAT = 2  # 1: task config only, no scene (read as the default scene)


def config_to_dict(config) -> dict:
    return json.loads(json.dumps(dataclasses.asdict(config)))


def config_from_dict(cls: type, data: dict):
    """The frozen dataclass ``cls`` from its recorded dict; fields missing from the record keep their defaults
    (a record of an older version), unknown fields are an error (a record of a newer one)."""
    if not isinstance(data, dict):
        raise DragMeshError(f"run record: {cls.__name__} must be an object, got {type(data).__name__}")
    hints = typing.get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls) if f.init}
    unknown = set(data) - names
    if unknown:
        raise DragMeshError(f"run record: unknown {cls.__name__} fields {sorted(unknown)}")
    return cls(**{k: _value(hints[k], v) for k, v in data.items()})


def _value(tp, v: Any):
    if v is None:
        return None
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        (arg,) = [a for a in typing.get_args(tp) if a is not type(None)][:1] or [Any]
        return _value(arg, v)
    if dataclasses.is_dataclass(tp):
        return config_from_dict(tp, v)
    if origin is tuple:
        args = typing.get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_value(args[0], x) for x in v)
        return tuple(_value(a, x) for a, x in zip(args, v, strict=True))
    return v


def versions() -> dict:
    out = {"python": platform.python_version()}
    for pkg in ("dragmesh2-jax", "jax", "jaxlib", "mujoco", "mujoco-mjx", "flax", "optax"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = None
    return out


def make_record(trainer, object_dir: str, seed: int | None = None, extra: dict | None = None) -> dict:
    """The record of a run of ``trainer`` (with ``seed`` instead of the config's, for one seed of several)."""
    from pathlib import Path

    ppo = trainer.config if seed is None else dataclasses.replace(trainer.config, seed=seed)
    task = trainer.task
    return {"format": RECORD_FORMAT, **(extra or {}), "method": trainer.method.name,
            "object": str(Path(object_dir).resolve()), "trajectory": "trajectory.json", "backend": task.backend.name,
            "ppo": config_to_dict(ppo), "task": config_to_dict(task.config), "scene": config_to_dict(task.scene.config),
            "versions": versions()}


def read_configs(meta: dict):
    """(PPOConfig, TaskConfig, SceneConfig) of a record."""
    from dragmesh2_jax.ppo.config import PPOConfig
    from dragmesh2_jax.scene import SceneConfig
    from dragmesh2_jax.task.config import TaskConfig

    for key in ("ppo", "task"):
        if key not in meta:
            raise DragMeshError(f"run record has no {key!r} config")
    return (config_from_dict(PPOConfig, meta["ppo"]), config_from_dict(TaskConfig, meta["task"]),
            config_from_dict(SceneConfig, meta.get("scene", {})))
