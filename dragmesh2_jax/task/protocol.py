"""The env protocol: what training, evaluation and the baselines may rely on, and nothing more.

An env (:class:`Env`) is one world: ``reset(key, damping_scale=None) -> State`` and ``step(state, action) -> State``
are pure functions of a :class:`State` pytree (batch them with ``jax.vmap``); ``restart(state)`` begins the world's next
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

from dragmesh2_jax.physics.base import Kinematics
from dragmesh2_jax.physics.contacts import ContactBudget
from dragmesh2_jax.task.config import ResetNoise, TaskConfig
from dragmesh2_jax.trajectory.schema import Trajectory

#: A step whose largest |a_i| exceeds this counts as saturated (clip099, design §8).
CLIP_LEVEL = 0.99
#: Control steps a start takes to settle: a perturbed start's hand reaches its grasp in its first 4-5 steps, faster
#: where the part resists, and begins 3-5 mm into the handle (the median on the shared objects; RESULTS.md §6b); the
#: settled figures (the evaluation's, the ``settled_palm_speed`` measure) leave them out.
START_STEPS = 5
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
    """What training, evaluation, an object mix and the benchmarks read of an env (``PullTask``, ``ObjectMix``)."""

    action_size: int
    active: jnp.ndarray  # (action_size,) bool: the channels that move something (the others locked)
    data: Any  # everything object-specific: an argument of every compiled program
    config: TaskConfig
    substeps: int  # physics steps per control step
    num_starts: int  # the start bank a reset draws from
    object_id: str  # the object's (a mix's first object's)
    engine: str  # the physics engine: "mujoco" (the C engine) or "mjx" (``config.resolved_impl()`` says which)
    budget: ContactBudget | None  # MJX's contact budget (static buffers); None on the C engine
    buffers: dict  # contact slots and constraint rows one world holds (None on the C engine)
    trajectories: tuple[Trajectory, ...]  # the reference trajectory of each object

    def bind(self, data: Any) -> Env: ...

    def signature(self) -> Hashable: ...

    def sized(self, worlds: int) -> Env:
        """The env for a batch of ``worlds`` worlds (an engine's shared buffers sized for them)."""
        ...

    def with_starts(self, starts: ResetNoise | None, costs: bool = False) -> Env:
        """The same objects and trajectories, reset from other starts (an evaluation protocol's); ``costs``: whether
        the constraints' costs are measured there (an evaluation's multipliers stay zero: it counts none)."""
        ...

    def check_overflow(self, count: int, where: str) -> None:
        """A clear error when ``count`` world-steps overflowed the engine's buffers."""
        ...

    def kinematics(self, state: State) -> Kinematics:
        """The quantities a world's ``state`` holds (hand, target joint, frames, loads: ``physics.base.Kinematics``)."""
        ...

    def reset(self, key: jax.Array, damping_scale: jax.Array | float | None = None, start=None) -> State:
        """A new episode; ``damping_scale`` fixes the world's damping multiplier (the one way to fix it: an
        evaluation cell's), kept by every ``restart`` of that world; ``start`` picks the start state."""
        ...

    def step(self, state: State, action: jnp.ndarray) -> State: ...

    def step_target(self, state: State, target: jnp.ndarray) -> State:
        """A step with the PD target given directly (controllers of ``controls == "targets"``)."""
        ...

    def restart(self, state: State) -> State:
        """A new episode for the world of ``state`` (its episode ended): fresh randomisation, but what the world
        fixes (an evaluation cell's damping) is kept. ``wrappers.AutoReset`` calls it."""
        ...

    def adaptive_weights(self) -> dict[str, jnp.ndarray]:
        """A new run's adaptive reward weights, by name: the trainer keeps them and knows nothing else of them."""
        ...

    def bind_weights(self, data: Any, weights: dict) -> Any:
        """``data`` with the adaptive weights ``weights`` bound in (an epoch's rollout)."""
        ...

    def update_weights(self, weights: dict, metrics: dict, steps: dict) -> tuple[dict, dict]:
        """The weights after an epoch (its ``metrics``; ``steps`` its per-step metrics) and the metrics with
        what moved them and their new values added."""
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
