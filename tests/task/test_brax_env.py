"""The task as a registered brax env (``task/brax_env.py``): ``brax.envs.get_environment`` builds it, it observes the
state and the contact history (what PICA reads), and brax's own PPO trains it for a tiny budget."""

import dataclasses
import math

import brax.envs
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from brax.training.agents.ppo import train as ppo

from dragmesh2_jax.baselines.brax_ppo import brax_ppo_kwargs
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.task.brax_env import ENV_NAME, BraxPullEnv
from tests.conftest import TINY_PPO

#: brax PPO's tiny budget: the tiny batch (4 worlds x 8 steps per update) for 64 updates, 2048 environment steps, on
#: episodes of 16 steps (so that some end, and brax's auto-reset and evaluation run).
TINY_UPDATES, TINY_EPISODE = 64, 16


def test_get_environment_builds_the_registered_env_observing_the_history(drawer_task):
    env = brax.envs.get_environment(ENV_NAME, task=drawer_task)
    assert isinstance(env, BraxPullEnv) and env.observation == "history" and env.task is drawer_task
    assert env.observation_size == 120 + 16 * 102 and env.action_size == 51
    s = env.step(env.reset(jax.random.PRNGKey(0)), jnp.full(51, 0.5))
    state, history = env.split(s.obs)
    np.testing.assert_array_equal(state, s.pipeline_state.obs.state)
    np.testing.assert_array_equal(history, s.pipeline_state.obs.history)  # H_t (16, 102), oldest first
    assert env.split(jnp.stack([s.obs] * 3))[1].shape == (3, 16, 102)
    assert {"success", "detach", "reward/bound"} <= set(s.metrics) and float(s.info["time_out"]) == 0.0
    assert BraxPullEnv(drawer_task).observation_size == 120  # the state-only baseline's default
    overridden = brax.envs.get_environment(ENV_NAME, task=drawer_task, config_overrides={"reward.w_bound": 5.0},
                                           observation="state")
    assert overridden.task.config.reward.w_bound == 5.0 and overridden.observation_size == 120
    with pytest.raises(DragMeshError, match="unknown observation"):
        BraxPullEnv(drawer_task, "pixels")


def test_brax_ppo_trains_the_registered_env_for_a_tiny_budget(drawer_task):
    env = brax.envs.get_environment(ENV_NAME, task=drawer_task, config_overrides={"episode_length": TINY_EPISODE})
    kwargs = brax_ppo_kwargs(dataclasses.replace(PPOConfig(), **TINY_PPO), env.episode_length, TINY_UPDATES, seed=0)
    # two evaluations (before and after), each of a few worlds: brax's EvalWrapper adds its own metrics to the state
    kwargs.update(num_evals=2, run_evals=True, num_eval_envs=4)
    curve = []
    make_policy, params, metrics = ppo.train(env, progress_fn=lambda step, m: curve.append(step), **kwargs)
    assert curve[0] == 0 and curve[-1] >= kwargs["num_timesteps"] == 2048
    assert np.isfinite(metrics["training/policy_loss"]) and np.isfinite(metrics["eval/episode_reward"])
    assert len(params) == 3 and math.prod(params[0].mean.shape) == env.observation_size  # normaliser, policy, value
    obs = env.reset(jax.random.PRNGKey(1)).obs
    action, _ = make_policy(params, deterministic=True)(obs, jax.random.PRNGKey(2))
    assert action.shape == (51,) and np.all(np.isfinite(action))
