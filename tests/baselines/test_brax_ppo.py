"""brax's PPO trains the state-only baseline on the task through the brax Env adapter; our evaluator scores it."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.baselines.brax_ppo import BRAX_STATE_ONLY, brax_ppo_kwargs, train_brax_ppo
from dragmesh2_jax.evaluation.evaluate import evaluate
from dragmesh2_jax.evaluation.protocol import EvalProtocol
from dragmesh2_jax.ppo.config import PAPER_EPOCHS, PPOConfig
from dragmesh2_jax.task.brax_env import BraxPullEnv


def test_the_task_as_a_brax_env(drawer_task):
    env = BraxPullEnv(drawer_task)
    assert env.observation_size == 120 and env.action_size == 51 and env.backend == "mujoco"
    s = env.reset(jax.random.PRNGKey(0))
    assert s.obs.shape == (120,) and float(s.done) == 0.0
    s = env.step(s.replace(info={**s.info, "steps": jnp.float32(0)}), jnp.zeros(51))
    assert s.info["steps"] == 0  # brax's wrappers keep their own bookkeeping in info
    np.testing.assert_array_equal(s.obs, s.pipeline_state.obs.state)
    assert float(s.reward) == float(s.pipeline_state.reward) and "time_out" in s.info


def test_brax_budget_equals_ours():
    c = PPOConfig()
    kw = brax_ppo_kwargs(c, episode_length=300, epochs=PAPER_EPOCHS, seed=3)
    steps_per_update = kw["batch_size"] * kw["num_minibatches"] * kw["unroll_length"]
    assert steps_per_update == c.num_envs * c.rollout_len  # 2048 environment steps per update, as ours
    assert kw["num_timesteps"] // steps_per_update == PAPER_EPOCHS and kw["seed"] == 3  # 150 updates
    assert kw["num_updates_per_batch"] == c.update_epochs and kw["learning_rate"] == c.lr


def test_brax_ppo_trains_state_only_and_our_evaluator_scores_it(drawer_task):
    config = dataclasses.replace(PPOConfig(), num_envs=4, rollout_len=8)
    controller, metrics = train_brax_ppo(drawer_task, config, epochs=2)
    assert controller.name == BRAX_STATE_ONLY and np.isfinite(metrics["training/policy_loss"])
    protocol = EvalProtocol(dampings=(1.0, 4.0), episodes=2)
    res = evaluate(protocol.task(drawer_task), controller, protocol)
    assert [(c["mode"], c["damping"]) for c in res["cells"]] == [("det", 1.0), ("det", 4.0), ("stoch", 1.0),
                                                                ("stoch", 4.0)]
    assert all(np.isfinite(c["return_mean"]) and c["steps_mean"] >= 1 for c in res["cells"])
