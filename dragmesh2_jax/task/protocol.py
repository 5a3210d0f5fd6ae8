"""The env protocol: what training, evaluation and the baselines may rely on, and nothing more.

An env is one world: ``reset(key, damping_scale=None) -> State`` and ``step(state, action) -> State`` are pure
functions of a :class:`State` pytree (batch them with ``jax.vmap``); ``restart(state)`` begins the world's next
episode (``wrappers.AutoReset`` calls it where an episode ended). Everything object-specific is the env's
``data``, an argument of every compiled program: ``bind(data)`` gives the same env over other data (another object
of the same structure, or the tracers of a traced function), and ``signature()`` says what else a compiled program
depends on (equal signatures share programs).

A step reports, per world:
  * ``reward``, ``done`` (terminated or truncated), ``terminated`` (success, detachment, non-finite physics: no
    bootstrap), ``truncated`` (time limit: bootstrap from the value of ``final_obs``);
  * ``obs``: the fields of :class:`Obs` (each policy reads what it may: see ``task/env.py`` for the layout);
  * ``metrics``: one scalar per name of :data:`METRICS`, belonging to the step just taken (and
    ``cost_<measure>`` for each constraint of the reward, ``rewards.cost_metric``, and ``reward/<term>`` for each
    term of the reward, ``rewards.term_names``).
"""

from __future__ import annotations

from collections.abc import Hashable
from typing import Any, Protocol

import jax
import jax.numpy as jnp
from flax import struct

#: A step whose largest |a_i| exceeds this counts as saturated (clip099, design §8).
CLIP_LEVEL = 0.99
#: Metric names of every step (one scalar per world, for the step just taken).
METRICS = ("success", "progress", "detach", "truncated", "action_abs_max", "active_abs_max", "action_l2", "palm_dist",
           "reward", "nonfinite", "overflow", "episode_return", "episode_length", "q")


@struct.dataclass
class Obs:
    state: jnp.ndarray  # s_t: the policy's state input
    history: jnp.ndarray  # H_t: the contact-history tokens, oldest first
    aux: jnp.ndarray  # y_t: auxiliary targets (a training target only, never a network input)
    privileged: jnp.ndarray  # what only an asymmetric critic may see (never an actor input)
    step: jnp.ndarray  # int32 control step within the episode (time-indexed controllers; no network input)


@struct.dataclass
class State:
    physics: Any
    obs: Obs
    reward: jnp.ndarray
    done: jnp.ndarray  # the episode ended at this step (terminated or truncated)
    terminated: jnp.ndarray
    truncated: jnp.ndarray
    final_obs: Obs  # the observation the step reached, before any automatic reset (for the value bootstrap)
    metrics: dict
    info: dict  # the env's own per-world state (rings, counters, its rng): no caller reads it


class Env(Protocol):
    action_size: int
    data: Any

    def bind(self, data: Any) -> Env: ...

    def signature(self) -> Hashable: ...

    def reset(self, key: jax.Array, damping_scale: jax.Array | float | None = None, start=None) -> State: ...

    def step(self, state: State, action: jnp.ndarray) -> State: ...

    def restart(self, state: State) -> State:
        """A new episode for the world of ``state`` (its episode ended): fresh randomisation, but what the world
        fixes (an evaluation cell's damping) is kept. ``wrappers.AutoReset`` calls it."""
        ...


def where(done: jnp.ndarray, fresh: Any, current: Any) -> Any:
    """``fresh`` where ``done``, else ``current`` (a world's physics state): a state with a ``where`` of its own merges
    by it (``mjx.Data.where``: MJX-Warp's state holds buffers the batch shares, which it keeps)."""
    if hasattr(current, "where"):
        return current.where(done, fresh)
    return jax.tree.map(lambda x, y: jnp.where(done, x, y), fresh, current)


def observation_spec(env: Env) -> Obs:
    """The shapes and dtypes of one world's observation (``jax.ShapeDtypeStruct`` leaves), without running it."""
    return jax.eval_shape(env.reset, jax.random.PRNGKey(0)).obs
