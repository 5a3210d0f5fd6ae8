"""The pulling task as a brax ``Env``: ``reset(rng)`` / ``step(state, action)`` over brax's ``State``, with
``observation_size`` and ``action_size``, so brax's training algorithms (``brax.training.agents.ppo.train``) run on it
unchanged. Importing this module registers it with brax under :data:`ENV_NAME`:

    import dragmesh2_jax.task.brax_env  # noqa: F401  (registers "dragmesh2_pull")
    env = brax.envs.get_environment("dragmesh2_pull", config_overrides={"episode_length": 100})
    make_policy, params, metrics = ppo.train(env, num_timesteps=..., episode_length=env.episode_length, ...)

``get_environment`` passes its keywords to :func:`make_brax_env`: what builds a Playground env
(``task/playground.PullEnv``: ``config``, ``config_overrides`` as dotted paths into the ``TaskConfig``,
``object_dir``, ``trajectory``, ``scene_config``, or a built ``task``) and ``observation``.

The observation (``observation``, one of :data:`OBSERVATIONS`), one flat vector per world (what brax's networks and
its observation normaliser read):
  ``"history"`` (the registered env's default): [s_t, H_t flattened], S + L*T values (120 + 16*102 = 1752 for the
                paper's task): the state and the contact-history window PICA reads, oldest token first;
                :meth:`BraxPullEnv.split` gives them back as s_t (S,) and H_t (L, T).
  ``"state"``   (the class's default): s_t only (S), as the state-only baseline sees it
                (``baselines/brax_ppo.py``).

brax's ``State.pipeline_state`` holds the task's whole :class:`~dragmesh2_jax.task.protocol.State` (brax's auto-reset
restores only it and ``obs``). ``done`` is the task's termination (success, detachment, non-finite physics): brax's
``EpisodeWrapper`` adds the time limit itself and marks it as a truncation, so the episode length given to brax must
be the task's (``episode_length``); ``info["time_out"]`` flags the task's time limit for brax's
``bootstrap_on_timeout``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import jax
import jax.numpy as jnp
from brax.envs import register_environment
from brax.envs.base import Env
from brax.envs.base import State as BraxState

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.task.config import TaskConfig
from dragmesh2_jax.task.env import PullTask
from dragmesh2_jax.task.playground import PullEnv, jax_compat, step_metrics
from dragmesh2_jax.task.protocol import State as TaskState
from dragmesh2_jax.task.protocol import observation_spec
from dragmesh2_jax.trajectory.schema import Trajectory

#: The name the task is registered under with brax (``brax.envs.get_environment``).
ENV_NAME = "dragmesh2_pull"
#: The observations the brax env offers (see the module's text).
OBSERVATIONS = ("history", "state")


class BraxPullEnv(Env):
    """``task`` seen through brax's environment interface (one world; brax's wrappers batch it), observing
    ``observation`` (one of :data:`OBSERVATIONS`)."""

    def __init__(self, task: PullTask, observation: str = "state"):
        if observation not in OBSERVATIONS:
            raise DragMeshError(f"unknown observation {observation!r} (choose from {', '.join(OBSERVATIONS)})")
        jax_compat()  # a brax env is made to be trained by brax
        self.task, self.observation = task, observation
        spec = observation_spec(task)
        self.state_size, self.history_shape = spec.state.shape[-1], tuple(spec.history.shape)
        self._obs_size = self.state_size + (math.prod(self.history_shape) if observation == "history" else 0)

    @property
    def episode_length(self) -> int:
        return self.task.config.episode_length

    @property
    def observation_size(self) -> int:
        return self._obs_size

    @property
    def action_size(self) -> int:
        return self.task.action_size

    @property
    def backend(self) -> str:
        return self.task.backend.name

    def reset(self, rng: jax.Array) -> BraxState:
        return self._wrap(self.task.reset(rng), {}, {})

    def step(self, state: BraxState, action: jax.Array) -> BraxState:
        return self._wrap(self.task.step(state.pipeline_state, action), state.info, state.metrics)

    def split(self, obs: jax.Array) -> tuple[jax.Array, jax.Array | None]:
        """s_t (..., S) and H_t (..., L, T) of observations (any leading axes); H_t is None under ``"state"``."""
        state = obs[..., :self.state_size]
        if self.observation == "state":
            return state, None
        return state, obs[..., self.state_size:].reshape(*obs.shape[:-1], *self.history_shape)

    def _obs(self, s: TaskState) -> jax.Array:
        if self.observation == "state":
            return s.obs.state
        return jnp.concatenate([s.obs.state, s.obs.history.reshape(-1)])

    def _wrap(self, s: TaskState, info: dict, metrics: dict) -> BraxState:
        """brax's state of task state ``s``; the info and metrics the wrappers added (``info``, ``metrics``: brax's
        EvalWrapper adds ``metrics["reward"]``) are kept, since a step must return the pytree it was given."""
        return BraxState(pipeline_state=s, obs=self._obs(s), reward=s.reward, done=s.terminated.astype(jnp.float32),
                         metrics={**metrics, **step_metrics(s)},
                         info={**info, "time_out": s.truncated.astype(jnp.float32)})


def make_brax_env(config: TaskConfig | None = None, config_overrides: Mapping[str, Any] | None = None, *,
                  object_dir: str | None = None, trajectory: str | Trajectory | None = None,
                  scene_config: SceneConfig | None = None, task: PullTask | None = None,
                  observation: str = "history") -> BraxPullEnv:
    """The brax env of the task that ``task/playground.PullEnv`` builds from these arguments, observing
    ``observation`` (default: the history, which PICA needs): what ``brax.envs.get_environment(ENV_NAME, ...)``
    returns."""
    env = PullEnv(config, config_overrides, object_dir=object_dir, trajectory=trajectory, scene_config=scene_config,
                  task=task)
    return BraxPullEnv(env.task, observation)


register_environment(ENV_NAME, make_brax_env)  # brax's registry takes any callable that returns an env
