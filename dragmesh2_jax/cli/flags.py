"""The command line's flag values: argparse types that refuse bad input when parsed, damping lists, and every field
of a run's configuration tree as a flag: ``--<group>.<field>`` for the task, scene, PPO and network configs, the
schedule's fields by their own names (``--epochs``, ``--seed``, ``--save-every``, ...)."""

from __future__ import annotations

import argparse
import dataclasses

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.policies.networks import NetworkConfig
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.runs.commands import parse_floats
from dragmesh2_jax.runs.spec import Schedule
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.task.config import TaskConfig


def parse_dampings(text: str, what: str = "--damping") -> list[float]:
    """Comma-separated damping multipliers (each > 0)."""
    return parse_floats(text, what, above=0.0)


def _whole(minimum: int):
    """An argparse type: a whole number >= ``minimum``, refused when parsed (one error line, exit 2)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"a whole number expected, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be >= {minimum}, got {value}")
        return value
    parse.__name__ = f"int>={minimum}"
    return parse


POSITIVE, NONNEGATIVE = _whole(1), _whole(0)


def one_damping(text: str) -> float:
    """An argparse type: one damping multiplier (> 0)."""
    try:
        (value,) = parse_dampings(text)
    except DragMeshError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    except ValueError:
        raise argparse.ArgumentTypeError(f"one damping multiplier expected, got {text!r}") from None
    return value


# ------------------------------------------------------------- every config field as a flag
#: Config dataclasses whose fields ``dragmesh2 train`` takes as flags, by their group in a run's spec.
CONFIG_CLASSES = {"schedule": Schedule, "task": TaskConfig, "scene": SceneConfig, "ppo": PPOConfig,
                  "network": NetworkConfig}
#: Groups whose flags go without the group's name: a run's schedule is what every run command asks for.
UNGROUPED = ("schedule",)
#: What each group's flags are, in ``--help``.
GROUP_HELP = {"schedule": "how the run is driven: its length in epochs (a resumed run: its own; more extend it), its "
                          "seed, its checkpoint and robustness-check intervals (--robust-every 0: no checks; a resumed "
                          "run: its own), the checkpoint that stands for it (best_robust | final) and the damping "
                          "cells it is evaluated at by default (none: the paper's x1/x2/x4)"}


def flag_name(group: str, name: str) -> str:
    """The flag of a config field: ``--ppo.num-minibatches``, a schedule's ``--save-every``."""
    name = name.replace("_", "-")
    return f"--{name}" if group in UNGROUPED else f"--{group}.{name}"


def _field_parser(tp):
    """An argparse type for a config field's annotation (scalars, optional scalars and tuples of numbers), or
    None for nested configs (set them in Python)."""
    text = str(tp)
    optional = "None" in text
    base = text.replace(" | None", "").replace("None | ", "").strip()
    scalar = {"int": int, "float": float, "str": str, "bool": _bool}.get(base)
    if scalar is not None:
        return (lambda s: None if s.lower() == "none" else scalar(s)) if optional else scalar
    if base.startswith("tuple[") and ("float" in base or "int" in base):
        num = float if "float" in base else int

        def tup(s):
            if optional and s.lower() == "none":
                return None
            return tuple(num(x) for x in s.split(",") if x.strip())
        return tup
    return None


def _bool(s: str) -> bool:
    if s.lower() not in ("true", "false", "1", "0"):
        raise argparse.ArgumentTypeError(f"expected true or false, got {s!r}")
    return s.lower() in ("true", "1")


def add_config_args(p: argparse.ArgumentParser, skip: tuple[str, ...] = ()) -> None:
    """``--epochs 300``, ``--task.alpha 0.03``, ``--ppo.num-envs 8``, ``--scene.damping 25``, ``--network.hist-dim
    64``: every scalar and tuple field of a run's schedule, task, scene, PPO and network configs (defaults: the
    method's)."""
    for prefix, cls in CONFIG_CLASSES.items():
        g = p.add_argument_group(f"{prefix} config ({cls.__name__}; default: the method's)", GROUP_HELP.get(prefix))
        for f in dataclasses.fields(cls):
            parse = _field_parser(f.type)
            if parse is None or f"{prefix}.{f.name}" in skip:
                continue
            g.add_argument(flag_name(prefix, f.name), dest=f"{prefix}__{f.name}", type=parse,
                           default=argparse.SUPPRESS, metavar=f.type if isinstance(f.type, str) else None,
                           help=f"default: the method's; {cls.__name__}'s {flag_value(f.default)}")


def flag_value(value) -> str:
    """A value as a flag writes it: a tuple comma-separated, a bool in lower case."""
    return ",".join(map(str, value)) if isinstance(value, tuple) else str(value).lower() if isinstance(
        value, bool) else str(value)


def config_changes(args, prefix: str) -> dict:
    """The flags of a group's fields given on the command line."""
    return {k.split("__", 1)[1]: v for k, v in vars(args).items() if k.startswith(f"{prefix}__")}

