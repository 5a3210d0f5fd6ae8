"""The pulling task as a MuJoCo Playground environment: the interface of Playground's ``MjxEnv``, so that code written
for Playground's envs (its brax training wrappers, a rollout loop, a model inspector) runs on ours.

    env = PullEnv(config_overrides={"reward.w_bound": 5.0, "backend": "mjx"})   # the packaged drawer
    state = jax.jit(env.reset)(jax.random.PRNGKey(0))
    state = jax.jit(env.step)(state, jnp.zeros(env.action_size))

What it offers, as Playground's envs do:
  * ``reset(rng) -> State`` and ``step(state, action) -> State`` for one world (batch them with ``jax.vmap``);
    ``State`` has Playground's fields ``data, obs, reward, done, metrics, info``;
  * ``observation_size`` (a dict of shapes: the observation is a dict), ``action_size`` (51: the hand's DoFs, actions
    in [-1, 1]), ``mj_model`` and ``mjx_model``, ``dt`` (control step), ``sim_dt``, ``n_substeps``, ``unwrapped``;
  * a config with overrides: the config is the project's :class:`~dragmesh2_jax.task.config.TaskConfig` itself,
    ``config_overrides`` dotted paths into it (``{"reward.w_bound": 5.0}``, ``{"episode_length": 100}``: the same
    reading as a run's ``--task.reward.w_bound``, :func:`~dragmesh2_jax.task.config.apply_overrides`). Playground
    envs take an ``ml_collections`` config; ours stays the frozen dataclass every run records, so a setting has one
    name and one check.

The observation (``obs``, a dict of flat vectors, Playground's form: brax's networks and observation normaliser read
one vector per key and world; each consumer takes what it may, as ``task/protocol.Obs``):
  ``state``      (S,)     s_t, the policy's state input (S = 120, ``task/env.py`` for the layout);
  ``history``    (L * T,) H_t flattened, the contact-history window PICA's encoder reads (``env.history_shape`` is
                          (L, T)): L = ``history_len`` (16) tokens [e_t, a_{t-1}] of T = 102 (124 with ``force_obs``),
                          oldest first;
  ``aux``        (4,)     y_t, the auxiliary targets: a training target, never a policy input;
  ``privileged`` (P,)     what only an asymmetric critic may see (damping and friction multipliers, contact load).
Train brax's PPO on it as Playground does: ``ppo.train(env, wrap_env_fn=wrap_for_brax_training, ...)`` with a
network factory that names the keys it reads (``policy_obs_key="state"``, ``value_obs_key="privileged"``).

Where it differs from Playground, and why:
  * ``data`` is the task's whole :class:`~dragmesh2_jax.task.protocol.State`, not an ``mjx.Data``: an auto-reset
    as Playground's (:func:`wrap_for_brax_training`) restores only ``data`` and ``obs`` where an episode ends, so
    everything an episode carries (the history ring, the step counter, the randomised multipliers) must live there.
    The physics is ``data.physics`` (an ``mjx.Data`` on MJX, a handle into the C engine's worlds on the C engine).
  * ``done`` is the task's termination (success, detachment, non-finite physics), as a float. The time limit is the
    task's ``episode_length``: the task reports it in ``info["time_out"]`` and in ``data.truncated``, not in ``done``,
    so that brax's ``EpisodeWrapper`` (given ``episode_length=env.episode_length``) marks it as a truncation and
    ``bootstrap_on_timeout`` bootstraps it. A loop of its own ends an episode at ``done`` or ``info["time_out"]``.
  * the engine is the config's (``backend``: "auto" is MJX on an accelerator, the C engine on a CPU, where it is
    faster; ``{"backend": "mjx"}`` forces MJX); ``mjx_model`` exists on MJX only. MJX-Warp shares its contact
    buffers across the batch: size them with ``env.sized(num_worlds)`` (MJX-JAX and the C engine need nothing).
  * no ``xml_path``: the scene is generated from the object (``scene.build_scene``), ``mj_model`` is its model.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

import jax
import jax.numpy as jnp
import mujoco
from brax.envs.wrappers import training as brax_training
from flax import struct

from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.task.config import TaskConfig, apply_overrides
from dragmesh2_jax.task.env import PullTask
from dragmesh2_jax.task.load import task_of
from dragmesh2_jax.task.protocol import Obs, observation_spec
from dragmesh2_jax.task.protocol import State as TaskState
from dragmesh2_jax.task.rewards import TERM_PREFIX
from dragmesh2_jax.trajectory.schema import Trajectory

#: The task metrics a step reports (Playground's and brax's episode wrappers sum each over an episode: the events are
#: 1 at the step they happen, so their sums are the events; the reward terms sum to the episode's return by term).
EPISODE_METRICS = ("success", "detach")


@struct.dataclass
class State:
    """One world of the env, in Playground's fields (see the module's text for ``data`` and ``done``)."""

    data: TaskState  # the task's whole state; the physics is data.physics
    obs: dict[str, jax.Array]
    reward: jax.Array
    done: jax.Array  # float32: the task terminated (the time limit is info["time_out"])
    metrics: dict[str, jax.Array]
    info: dict[str, Any]


def observation(obs: Obs) -> dict[str, jax.Array]:
    """The env's dict observation of the task's :class:`Obs` (its network inputs and targets, not its step count),
    one flat vector per key."""
    return {"state": obs.state, "history": obs.history.reshape(*obs.history.shape[:-2], -1), "aux": obs.aux,
            "privileged": obs.privileged}


def step_metrics(s: TaskState) -> dict[str, jax.Array]:
    """What an env reports of a task step for its episode wrappers to sum: the events and the reward's terms."""
    return {m: s.metrics[m] for m in EPISODE_METRICS} | {k: v for k, v in s.metrics.items()
                                                         if k.startswith(TERM_PREFIX)}


def _device_put_replicated(x: Any, devices: list) -> Any:
    """``x`` stacked once per device (``pmap`` places the copies): what ``jax.device_put_replicated`` did."""
    return jax.tree.map(lambda a: jnp.stack([jnp.asarray(a)] * len(devices)), x)


def jax_compat() -> None:
    """brax 0.14.2 (the newest release) still calls ``jax.device_put_replicated``, which jax 0.10 removed: put it
    back, so that brax's trainers run on a brax env of ours however it was made."""
    if not hasattr(jax, "device_put_replicated"):
        jax.device_put_replicated = _device_put_replicated


def default_config() -> TaskConfig:
    """The paper's task (Playground's envs name their defaults so): the one ``config_overrides`` change."""
    return TaskConfig()


class PullEnv:
    """The task of one object as a Playground env (one world; ``jax.vmap`` batches it).

    Built from what builds a task: ``object_dir`` (default: the packaged drawer), ``trajectory`` (a file or a
    :class:`Trajectory`; None: generated, a few seconds), ``scene_config``, and ``config`` (default
    :func:`default_config`) with ``config_overrides``; or over a ``task`` already built (its config is then the one
    the overrides change, and its scene and trajectory are kept)."""

    def __init__(self, config: TaskConfig | None = None, config_overrides: Mapping[str, Any] | None = None, *,
                 object_dir: str | None = None, trajectory: str | Trajectory | None = None,
                 scene_config: SceneConfig | None = None, task: PullTask | None = None):
        if task is not None and not (config is None and object_dir is None and trajectory is None
                                     and scene_config is None):
            raise DragMeshError("give either a built task or what builds one (config, object_dir, trajectory, "
                                "scene_config), not both")
        base = task.config if task is not None else config or default_config()
        self._config = apply_overrides(base, config_overrides or {})
        if task is None:
            task = task_of(object_dir or str(default_object()), trajectory, self._config, scene_config or SceneConfig())
        elif self._config != task.config:  # the same object and trajectory under the changed config
            task = PullTask(task.scene, task.traj, self._config)
        self.task = task
        self._obs_shape: dict[str, tuple[int, ...]] | None = None

    # ------------------------------------------------------------------------------------- the interface
    def reset(self, rng: jax.Array) -> State:
        """A new episode from ``rng`` (a start of the task's bank and the randomised multipliers drawn from it)."""
        return self._wrap(self.task.reset(rng), {}, {})

    def step(self, state: State, action: jax.Array) -> State:
        """One control step of ``action`` (51 values in [-1, 1]: the PD targets' increments over ``alpha``)."""
        return self._wrap(self.task.step(state.data, action), state.info, state.metrics)

    @property
    def config(self) -> TaskConfig:
        return self._config

    @property
    def observation_size(self) -> dict[str, tuple[int, ...]]:
        """The shape of each observation entry (Playground's form for a dict observation), without running a reset."""
        if self._obs_shape is None:
            obs = jax.eval_shape(self.reset, jax.random.PRNGKey(0)).obs
            self._obs_shape = {k: tuple(v.shape) for k, v in obs.items()}
        return self._obs_shape

    @property
    def history_shape(self) -> tuple[int, int]:
        """(L, T): the tokens of the history window and each token's size (``obs["history"]`` is it flattened)."""
        length, token = observation_spec(self.task).history.shape
        return int(length), int(token)

    @property
    def action_size(self) -> int:
        return self.task.action_size

    @property
    def mj_model(self) -> mujoco.MjModel:
        """The MuJoCo model the engine steps (on MJX-JAX with a contact cap, the scene's with its cap)."""
        return self.task.backend.model if self.task.engine == "mjx" else self.task.scene.model

    @property
    def mjx_model(self) -> Any:
        """The ``mjx.Model`` the engine steps (nominal: each world's randomised fields replace its own per step)."""
        if self.task.engine != "mjx":
            raise DragMeshError("this env runs on the C engine, which has no MJX model: build it with "
                                "config_overrides={'backend': 'mjx'}")
        return self.task.data.physics.model

    @property
    def dt(self) -> float:
        """The control step (s)."""
        return self._config.control_dt

    @property
    def sim_dt(self) -> float:
        """The physics step (s)."""
        return self.task.scene.config.timestep

    @property
    def n_substeps(self) -> int:
        return self.task.substeps

    @property
    def episode_length(self) -> int:
        """The task's time limit in control steps: the ``episode_length`` to give brax's training wrappers."""
        return self._config.episode_length

    @property
    def unwrapped(self) -> PullEnv:
        return self

    def sized(self, worlds: int) -> PullEnv:
        """This env for a batch of ``worlds`` worlds (MJX-Warp's shared contact buffers sized for them)."""
        env = copy.copy(self)
        env.task = self.task.sized(worlds)
        return env

    @staticmethod
    def _wrap(s: TaskState, info: dict, metrics: dict) -> State:
        """The env's state of task state ``s``; the info and metrics the wrappers added (``info``, ``metrics``) are
        kept, since a step must return the pytree it was given."""
        return State(data=s, obs=observation(s.obs), reward=s.reward, done=s.terminated.astype(jnp.float32),
                     metrics={**metrics, **step_metrics(s)}, info={**info, "time_out": s.truncated.astype(jnp.float32)})


class _AutoReset(brax_training.Wrapper):
    """Playground's auto-reset for an env whose state is ``data``: a world whose episode ended (``done``, or the
    time limit of brax's ``EpisodeWrapper`` below it) starts again from its first state (its first observation and
    whole task state, history and multipliers included)."""

    def reset(self, rng: jax.Array) -> State:
        state = self.env.reset(rng)
        state.info["first_data"], state.info["first_obs"] = state.data, state.obs
        return state

    def step(self, state: State, action: jax.Array) -> State:
        if "steps" in state.info:  # brax's EpisodeWrapper counts from 0 again in a restarted world
            state.info["steps"] = jnp.where(state.done, 0, state.info["steps"])
        state = self.env.step(state.replace(done=jnp.zeros_like(state.done)), action)
        done = state.done

        def where_done(first: jax.Array, now: jax.Array) -> jax.Array:
            return jnp.where(done.reshape(done.shape + (1,) * (now.ndim - done.ndim)), first, now)

        return state.replace(data=jax.tree.map(where_done, state.info["first_data"], state.data),
                             obs=jax.tree.map(where_done, state.info["first_obs"], state.obs))


def wrap_for_brax_training(env: PullEnv, episode_length: int = 1000, action_repeat: int = 1,
                           randomization_fn: Any = None) -> brax_training.Wrapper:
    """The ``wrap_env_fn`` for brax's ``ppo.train`` (Playground's ``wrap_for_brax_training``): brax's time limit and
    batch over the env, then an auto-reset that knows the state's ``data``. The damping and friction randomisation
    is the task's own (drawn at each reset), so ``randomization_fn`` (brax's per-model one) is refused."""
    if randomization_fn is not None:
        raise DragMeshError("the task randomises its worlds itself (TaskConfig.damping_range, friction_range): "
                            "give no randomization_fn")
    jax_compat()
    return _AutoReset(brax_training.VmapWrapper(brax_training.EpisodeWrapper(env, episode_length, action_repeat)))
