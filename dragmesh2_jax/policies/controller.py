"""What the evaluator runs: a policy ``(params, obs, key) -> output`` (Brax's ``make_inference_fn`` shape) with its
parameters. Trained runs, the tracking baselines, brax's policies and the parallel-jaw primitive are all one."""

from __future__ import annotations

from collections.abc import Callable, Hashable
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp

from dragmesh2_jax.task.protocol import Obs

Policy = Callable[[Any, Obs, jax.Array], jnp.ndarray]
#: What a policy outputs: actions a in [-1, 1]^51 (target = q_hand + alpha a: every learned policy), or the hand
#: PD targets themselves (scripted controllers such as the tracking baseline).
CONTROLS = ("actions", "targets")


@dataclass(frozen=True)
class Controller:
    """``make_policy(deterministic) -> Policy`` with its ``params``; ``key``: what make_policy's functions depend on
    besides params (shares compiled rollouts between checkpoints and objects of one structure)."""

    name: str
    make_policy: Callable[[bool], Policy]
    params: Any
    controls: str = "actions"
    key: Hashable | None = None

    def __post_init__(self):
        if self.controls not in CONTROLS:
            raise ValueError(f"controls must be one of {CONTROLS}, got {self.controls!r}")
