"""Configs as JSON and back: ``config_from_dict`` turns a recorded config into its frozen dataclass (tuples,
optional and nested configs included), so evaluation, resume and fine-tunes rebuild the task and scene the run
trained on, not the defaults. Anything malformed is one :class:`DragMeshError` line naming what is wrong."""

from __future__ import annotations

import dataclasses
import json
import platform
import types
import typing
from importlib import metadata
from typing import Any

from dragmesh2_jax.errors import DragMeshError


def config_to_dict(config) -> dict:
    return json.loads(json.dumps(dataclasses.asdict(config)))


def config_from_dict(cls: type, data: Any, where: str = "run record"):
    """The frozen dataclass ``cls`` from its recorded dict; fields missing from the record keep their defaults, a
    record of an earlier version is brought up to date by ``cls.upgrade`` where the class has one, unknown fields,
    values of the wrong kind and values the config rejects are one error line."""
    if not isinstance(data, dict):
        raise DragMeshError(f"{where}: {cls.__name__} must be an object, got {type(data).__name__}")
    if hasattr(cls, "upgrade"):  # a record written before a field was renamed or retired
        data = cls.upgrade(dict(data))
    hints = typing.get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls) if f.init}
    unknown = set(data) - names
    if unknown:
        raise DragMeshError(f"{where}: unknown {cls.__name__} fields {sorted(unknown)}")
    try:
        return cls(**{k: _value(hints[k], v, f"{where}: {cls.__name__}.{k}") for k, v in data.items()})
    except DragMeshError as e:
        raise DragMeshError(f"{where}: {e}" if not str(e).startswith(where) else str(e)) from None
    except (TypeError, ValueError) as e:
        raise DragMeshError(f"{where}: {cls.__name__} rejects the recorded values ({e})") from None


def _value(tp, v: Any, where: str):
    if v is None:
        return None
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        (arg,) = [a for a in typing.get_args(tp) if a is not type(None)][:1] or [Any]
        return _value(arg, v, where)
    if dataclasses.is_dataclass(tp):
        return config_from_dict(tp, v, where)
    if origin is tuple:
        if not isinstance(v, list | tuple):
            raise DragMeshError(f"{where}: expected a list, got {type(v).__name__}")
        args = typing.get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_value(args[0], x, where) for x in v)
        if len(args) != len(v):
            raise DragMeshError(f"{where}: expected {len(args)} values, got {len(v)}")
        return tuple(_value(a, x, where) for a, x in zip(args, v, strict=True))
    if tp in (int, float) and (isinstance(v, bool) or not isinstance(v, int | float)):
        raise DragMeshError(f"{where}: expected a number, got {v!r}")
    if tp is int and isinstance(v, float) and not v.is_integer():
        raise DragMeshError(f"{where}: expected a whole number, got {v!r}")
    if tp is bool and not isinstance(v, bool):
        raise DragMeshError(f"{where}: expected true or false, got {v!r}")
    if tp is str and not isinstance(v, str):
        raise DragMeshError(f"{where}: expected a string, got {v!r}")
    return int(v) if tp is int else float(v) if tp is float else v


def versions() -> dict:
    out = {"python": platform.python_version()}
    for pkg in ("dragmesh2-jax", "jax", "jaxlib", "mujoco", "mujoco-mjx", "flax", "optax"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = None
    return out
