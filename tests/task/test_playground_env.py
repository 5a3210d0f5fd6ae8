"""The task as a MuJoCo Playground env (``task/playground.py``): reset and step under jit on a batch, on MJX, with
Playground's sizes and models; its config is the TaskConfig, changed by dotted paths that reach the task."""

import dataclasses
import functools

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from brax.training.agents.ppo import networks as ppo_networks
from brax.training.agents.ppo import train as ppo

from dragmesh2_jax.baselines.brax_ppo import brax_ppo_kwargs
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.task.playground import PullEnv, default_config, wrap_for_brax_training
from tests.conftest import TINY_PPO, require_warp

#: One world's observation of the paper's task: s_t, H_t (L=16 tokens of [e_t, a_{t-1}]), y_t, the critic's inputs.
SIZES = {"state": (120,), "history": (16 * 102,), "aux": (4,), "privileged": (24,)}
HISTORY = (16, 102)
WORLDS = 2  # a tiny batch: MJX on a CPU can deadlock from about 5 worlds (RESULTS.md §1)


@pytest.mark.mjx
def test_the_playground_env_resets_and_steps_a_batch_under_jit_on_mjx(drawer_task):
    """On MJX-Warp (its compile is the cheaper one on a CPU; the env is the same on MJX-JAX, whose step the tracking
    and mix tests compile)."""
    require_warp()
    env = PullEnv(task=drawer_task, config_overrides={"backend": "mjx", "impl": "warp"})
    assert env.task.engine == "mjx" and env.config.backend == "mjx" and drawer_task.engine == "mujoco"
    assert env.observation_size == SIZES and env.history_shape == HISTORY and env.action_size == 51
    assert env.unwrapped is env
    assert isinstance(env.mj_model, mujoco.MjModel) and env.mjx_model.nq == env.mj_model.nq
    assert (env.dt, env.n_substeps) == (pytest.approx(1 / 60), 4)
    assert env.sim_dt * env.n_substeps == pytest.approx(env.dt)
    reset, step = jax.jit(jax.vmap(env.reset)), jax.jit(jax.vmap(env.step))
    s0 = reset(jax.random.split(jax.random.PRNGKey(0), WORLDS))
    assert {k: v.shape for k, v in s0.obs.items()} == {k: (WORLDS, *v) for k, v in SIZES.items()}
    action = jnp.full((WORLDS, env.action_size), 0.5)
    s1 = step(s0, action)
    assert s1.reward.shape == s1.done.shape == (WORLDS,) and np.all(np.isfinite(s1.reward))
    assert s1.done.dtype == jnp.float32 and not np.any(s1.done) and not np.any(s1.info["time_out"])
    assert type(s1.data.physics).__name__ == "Data"  # the MJX world state, at data.physics
    h0, h1 = (s.obs["history"].reshape(WORLDS, *HISTORY) for s in (s0, s1))
    np.testing.assert_array_equal(h1[:, :-1], h0[:, 1:])  # the window moved one token
    np.testing.assert_allclose(h1[:, -1, 51:], action)  # whose newest holds the action just applied
    assert np.all(s1.data.obs.step == 1) and {"success", "detach", "reward/bound"} <= set(s1.metrics)


def test_config_overrides_are_dotted_paths_that_reach_the_task(drawer_task):
    env = PullEnv(task=drawer_task, config_overrides={"reward.w_bound": 5.0, "episode_length": 20})
    assert env.task.config is env.config and (env.config.reward.w_bound, env.episode_length) == (5.0, 20)
    assert dataclasses.replace(env.config, reward=drawer_task.config.reward, episode_length=300) == drawer_task.config
    assert env.task.scene is drawer_task.scene and env.task.traj is drawer_task.traj  # the same object, rebuilt
    s = env.step(env.reset(jax.random.PRNGKey(0)), jnp.ones(env.action_size))  # |a| = 1 > a_sat = 0.9
    assert float(s.metrics["reward/bound"]) == pytest.approx(-5.0 * 0.1**2, rel=1e-4)  # the task's reward read it
    assert PullEnv(task=drawer_task).task is drawer_task  # no override: the task itself
    with pytest.raises(DragMeshError, match="reward.w_bond"):
        PullEnv(task=drawer_task, config_overrides={"reward.w_bond": 1.0})
    with pytest.raises(DragMeshError, match="not both"):
        PullEnv(default_config(), task=drawer_task)
    with pytest.raises(DragMeshError, match="no MJX model"):
        env.mjx_model  # noqa: B018  (the C engine's env)


def test_the_playground_env_builds_its_task_from_the_config(drawer_task):
    env = PullEnv(config_overrides={"reward.w_bound": 5.0, "backend": "mujoco"})  # the packaged drawer, generated
    assert env.task.object_id == drawer_task.object_id and env.task.config == env.config
    assert env.config == dataclasses.replace(default_config(), backend="mujoco",
                                             reward=dataclasses.replace(default_config().reward, w_bound=5.0))


def test_the_auto_reset_starts_a_world_again_from_its_first_state_where_its_episode_ends(drawer_task):
    env = wrap_for_brax_training(PullEnv(task=drawer_task), episode_length=2)
    first = env.reset(jax.random.split(jax.random.PRNGKey(0), WORLDS))
    action = jnp.full((WORLDS, 51), 0.5)
    one = env.step(first, action)
    assert not np.any(one.done) and np.all(one.data.obs.step == 1) and np.all(one.info["steps"] == 1)
    two = env.step(one, action)  # the time limit: brax's EpisodeWrapper ends the episode, the world starts again
    assert np.all(two.done) and np.all(two.info["truncation"] == 1) and np.all(two.data.obs.step == 0)
    np.testing.assert_array_equal(two.obs["state"], first.obs["state"])
    three = env.step(two, action)
    assert not np.any(three.done) and np.all(three.info["steps"] == 1) and np.all(three.data.obs.step == 1)
    with pytest.raises(DragMeshError, match="randomization_fn"):
        wrap_for_brax_training(PullEnv(task=drawer_task), randomization_fn=lambda model: (model, None))


def test_brax_ppo_trains_the_playground_env_for_a_tiny_budget_as_playground_does(drawer_task):
    env = PullEnv(task=drawer_task, config_overrides={"episode_length": 16})
    kwargs = brax_ppo_kwargs(dataclasses.replace(PPOConfig(), **TINY_PPO), env.episode_length, 64, seed=0)
    kwargs.update(num_evals=2, run_evals=True, num_eval_envs=4)  # before and after: the eval env wrapped the same way
    # the policy reads s_t and the critic the privileged state: the dict observation's keys, as Playground's nets
    networks = functools.partial(ppo_networks.make_ppo_networks, policy_obs_key="state", value_obs_key="privileged")
    curve = []
    make_policy, params, metrics = ppo.train(env, network_factory=networks, wrap_env_fn=wrap_for_brax_training,
                                             progress_fn=lambda step, m: curve.append(step), **kwargs)
    assert curve[0] == 0 and curve[-1] >= kwargs["num_timesteps"] == 2048
    assert np.isfinite(metrics["training/policy_loss"]) and np.isfinite(metrics["eval/episode_reward"])
    assert set(params[0].mean) == set(SIZES)  # the normaliser saw every key, each one flat
    obs = env.reset(jax.random.PRNGKey(1)).obs
    action, _ = make_policy(params, deterministic=True)(obs, jax.random.PRNGKey(2))
    assert action.shape == (51,) and np.all(np.isfinite(action))
