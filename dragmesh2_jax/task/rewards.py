"""Reward terms (paper Appendix A.3, eq. totalreward) as pure functions of one world's step quantities."""

from __future__ import annotations

import jax.numpy as jnp

from dragmesh2_jax.task.config import RewardConfig


def reward_terms(cfg: RewardConfig, action: jnp.ndarray, d: jnp.ndarray, dq: jnp.ndarray, success: jnp.ndarray,
                 detach: jnp.ndarray) -> dict[str, jnp.ndarray]:
    """Every term of r_t. ``action`` (51,) clipped to [-1, 1]; ``d`` palm-handle distance (m); ``dq`` target-joint
    increment q_t - q_{t-1}; ``success``/``detach`` this step's one-shot events."""
    return {
        "task": cfg.w_task * dq,
        "dist": -cfg.w_dist * d + cfg.w_near * jnp.exp(-cfg.kappa * d),
        "act": -cfg.w_act * jnp.mean(action**2),
        "time": -cfg.w_time * jnp.ones_like(d),
        "detach": cfg.r_detach * detach,
        "success": cfg.r_success * success,
        "bound": -cfg.w_bound * jnp.mean(jnp.maximum(jnp.abs(action) - cfg.a_sat, 0.0) ** 2),
        "contact": -cfg.w_contact * jnp.maximum(d - cfg.d_safe, 0.0) ** 2,
    }
