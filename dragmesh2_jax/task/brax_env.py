"""The pulling task as a brax ``Env`` (Playground's ``MjxEnv`` shape): ``reset(rng)`` / ``step(state, action)``
over brax's ``State``, with ``observation_size`` and ``action_size``, so brax's training algorithms
(``brax.training.agents.ppo.train``) run on it unchanged.

brax's ``State.pipeline_state`` holds the task's whole :class:`~dragmesh2_jax.task.protocol.State`; the observation is
s_t (``obs.state``), as the state-only baseline sees it. ``done`` is the task's termination (success, detachment,
non-finite physics): brax's ``EpisodeWrapper`` adds the time limit itself and marks it as a truncation, so the
episode length must be the task's (``episode_length``); ``info["time_out"]`` flags the task's time limit for
brax's ``bootstrap_on_timeout``.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from brax.envs.base import Env
from brax.envs.base import State as BraxState

from dragmesh2_jax.task.env import PullTask
from dragmesh2_jax.task.protocol import State as TaskState

#: The task metrics brax accumulates per episode (each is 1 at the step it happens, so the sum is the event).
EPISODE_METRICS = ("success", "detach")


class BraxPullEnv(Env):
    """``task`` seen through brax's environment interface (one world; brax's wrappers batch it)."""

    def __init__(self, task: PullTask):
        self.task = task
        self._obs_size = jax.eval_shape(task.reset, jax.random.PRNGKey(0)).obs.state.shape[-1]

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
        return self._wrap(self.task.reset(rng), {})

    def step(self, state: BraxState, action: jax.Array) -> BraxState:
        return self._wrap(self.task.step(state.pipeline_state, action), state.info)  # the wrappers' info kept

    @staticmethod
    def _wrap(s: TaskState, info: dict) -> BraxState:
        return BraxState(pipeline_state=s, obs=s.obs.state, reward=s.reward, done=s.terminated.astype(jnp.float32),
                         metrics={m: s.metrics[m] for m in EPISODE_METRICS},
                         info={**info, "time_out": s.truncated.astype(jnp.float32)})
