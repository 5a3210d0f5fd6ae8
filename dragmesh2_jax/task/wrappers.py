"""Wrappers over an env of ``task/protocol.py`` (MuJoCo Playground's ``wrapper.py`` pattern).

:class:`AutoReset` restarts a world in the step its episode ends (``env.restart``): the returned reward, done
flags, metrics and ``final_obs`` belong to the finished step, the physics, observation and info to the new episode.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from dragmesh2_jax.task.protocol import Env, State, where


class AutoReset:
    """``env`` whose finished worlds start a new episode inside ``step``."""

    def __init__(self, env: Env):
        self.env = env
        self.action_size, self.data = env.action_size, env.data

    def bind(self, data) -> AutoReset:
        return AutoReset(self.env.bind(data))

    def signature(self):
        return "auto_reset", self.env.signature()

    def reset(self, key: jax.Array, damping_scale=None, start=None) -> State:
        return self.env.reset(key, damping_scale, start)

    def step(self, state: State, action: jnp.ndarray) -> State:
        return self._restart_finished(self.env.step(state, action))

    def step_target(self, state: State, target: jnp.ndarray) -> State:
        return self._restart_finished(self.env.step_target(state, target))

    def _restart_finished(self, new: State) -> State:
        fresh = self.env.restart(new)
        pick = lambda x, y: jnp.where(new.done, x, y)  # noqa: E731
        keep = {"rng": fresh.info["rng"]}  # the world's rng moves on whether or not it restarted
        return new.replace(physics=where(new.done, fresh.physics, new.physics),
                           obs=jax.tree.map(pick, fresh.obs, new.obs),
                           info=jax.tree.map(pick, fresh.info, {**new.info, **keep}))
