"""The state-only baseline trained by brax's PPO (``brax.training.agents.ppo.train``) on the task through
:class:`~dragmesh2_jax.task.brax_env.BraxPullEnv`: an independent implementation to check ours against.

The budget and the hyper-parameters are ours (:class:`~dragmesh2_jax.ppo.config.PPOConfig`, paper Table 11)
mapped onto brax's arguments: the same environment steps per update (num_envs x rollout_len), updates, learning
rate, discount, GAE, clipping, value coefficient, gradient clipping and observation normalisation, and a Gaussian
policy with a state-independent log std starting at ours (the actions are clipped to [-1, 1] by the task). What
differs is brax's own: separate policy and value MLPs (ours share the trunk), no value normalisation, time
limits bootstrapped by adding gamma V(s_T) to the reward. The trained policy is evaluated by our evaluator.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import flax.linen as nn
from brax.training.agents.ppo import networks as ppo_networks
from brax.training.agents.ppo import train as ppo

from dragmesh2_jax.policies.controller import Controller
from dragmesh2_jax.policies.networks import NetworkConfig
from dragmesh2_jax.ppo.config import PAPER_EPOCHS, PPOConfig
from dragmesh2_jax.task.brax_env import BraxPullEnv
from dragmesh2_jax.task.env import PullTask

BRAX_STATE_ONLY = "brax_state_only"
NETWORK = NetworkConfig()  # our state MLP's sizes (for brax's policy and value networks) and initial log std


def brax_ppo_kwargs(config: PPOConfig, episode_length: int, epochs: int = PAPER_EPOCHS, seed: int = 42) -> dict:
    """brax ``ppo.train`` arguments for ``config``'s hyper-parameters and ``epochs`` of our updates' budget from
    ``seed`` (a run's schedule)."""
    if config.num_envs % config.num_minibatches:
        raise ValueError("brax needs num_envs divisible by num_minibatches")
    return dict(
        num_timesteps=epochs * config.num_envs * config.rollout_len, num_evals=2, run_evals=False,
        num_envs=config.num_envs, episode_length=episode_length, unroll_length=config.rollout_len,
        batch_size=config.num_envs // config.num_minibatches, num_minibatches=config.num_minibatches,
        num_updates_per_batch=config.update_epochs, learning_rate=config.lr, discounting=config.gamma,
        gae_lambda=config.gae_lambda, clipping_epsilon=config.clip_eps, entropy_cost=config.entropy_coef,
        vf_loss_coefficient=config.value_coef, max_grad_norm=config.max_grad_norm,
        normalize_observations=config.normalize_obs, normalize_advantage=config.normalize_advantage,
        bootstrap_on_timeout=True, seed=seed)


def train_brax_ppo(task: PullTask, config: PPOConfig = PPOConfig(), epochs: int = PAPER_EPOCHS,
                   seed: int = 42) -> tuple[Controller, dict]:
    """Train state-only PPO with brax on ``task`` (the state-only preset's task) for ``epochs`` of our updates'
    budget from ``seed``; returns the trained policy as the evaluator's :class:`Controller` and brax's final
    training metrics."""
    env = BraxPullEnv(task)  # state-only: s_t (its construction lets brax 0.14 run on jax 0.10)
    network_factory = functools.partial(
        ppo_networks.make_ppo_networks, policy_hidden_layer_sizes=NETWORK.state_sizes,
        value_hidden_layer_sizes=NETWORK.state_sizes,
        activation=nn.elu, distribution_type="normal", noise_std_type="log",
        init_noise_std=math.exp(NETWORK.log_std_init))
    make_policy, params, metrics = ppo.train(env, network_factory=network_factory,
                                             **brax_ppo_kwargs(config, env.episode_length, epochs, seed))
    return brax_controller(make_policy, params), {k: float(v) for k, v in metrics.items()}


def brax_controller(make_policy, params: Any) -> Controller:
    """A brax policy (``make_policy(params, deterministic)(obs, key) -> (action, extras)``) on s_t as a
    :class:`Controller`: det is the Gaussian mean, stoch a sample."""
    def make(deterministic: bool):
        return lambda p, obs, key: make_policy(p, deterministic)(obs.state, key)[0]

    return Controller(BRAX_STATE_ONLY, make, params)
