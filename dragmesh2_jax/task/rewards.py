"""Reward terms (paper Appendix A.3, eq. totalreward) as pure functions of one world's step quantities, and the
reward's adaptive weights (ARAM's lambda, the constraints' Lagrange multipliers): their start values and the rules
that move them once per epoch (the trainer calls them through the task's hook, ``PullTask.update_weights``)."""

from __future__ import annotations

import jax.numpy as jnp

from dragmesh2_jax.task.config import PEAK_COSTS, AramConfig, Constraint, ReconfigConfig, RewardConfig


def load_excess(wrist_force: jnp.ndarray, limit: float) -> jnp.ndarray:
    """max(0, |F| - limit) / limit: the wrist's pull beyond what the grasp holds, as a fraction of it."""
    return jnp.maximum(jnp.linalg.norm(wrist_force) - limit, 0.0) / limit


#: The terms every reward has (``reward_terms``); the constraints', ARAM's and Reconfig's join when configured.
BASE_TERMS = ("load", "task", "dist", "act", "time", "detach", "success", "bound", "contact")
#: A reward term's name among a step's metrics and in the training log.
TERM_PREFIX = "reward/"
#: A constraint's per-step cost's name among a step's metrics (``cost_metric``).
COST_PREFIX = "cost_"


def term_names(cfg: RewardConfig) -> tuple[str, ...]:
    """The names of r_t's terms under ``cfg``, in the order they are summed."""
    return (BASE_TERMS + (("constraints",) if cfg.constraints else ()) + (("aram",) if cfg.aram is not None else ())
            + (("reconfig",) if cfg.reconfig is not None else ()))


def reward_terms(cfg: RewardConfig, action: jnp.ndarray, d: jnp.ndarray, dq: jnp.ndarray, success: jnp.ndarray,
                 detach: jnp.ndarray, wrist_force: jnp.ndarray) -> dict[str, jnp.ndarray]:
    """Every term of r_t. ``action`` (51,) clipped to [-1, 1]; ``d`` palm-handle distance (m); ``dq`` target-joint
    increment q_t - q_{t-1}; ``success``/``detach`` this step's one-shot events; ``wrist_force`` (3,) N."""
    return {
        "load": -cfg.w_load * load_excess(wrist_force, cfg.f_hold),
        "task": cfg.w_task * dq,
        "dist": -cfg.w_dist * d + cfg.w_near * jnp.exp(-cfg.kappa * d),
        "act": -cfg.w_act * jnp.mean(action**2),
        "time": -cfg.w_time * jnp.ones_like(d),
        "detach": cfg.r_detach * detach,
        "success": cfg.r_success * success,
        "bound": -cfg.w_bound * jnp.mean(jnp.maximum(jnp.abs(action) - cfg.a_sat, 0.0) ** 2),
        "contact": -cfg.w_contact * jnp.maximum(d - cfg.d_safe, 0.0) ** 2,
    }


def initial_weights(cfg: RewardConfig) -> dict[str, jnp.ndarray]:
    """The adaptive weights of a new run: ARAM's lambda 0 and one multiplier 0 per constraint (in its order)."""
    return {"aram_lambda": jnp.float32(0.0), "multipliers": jnp.zeros(len(cfg.constraints), jnp.float32)}


def bound_weights(cfg: RewardConfig, weights: dict) -> dict:
    """Those of ``weights`` the reward under ``cfg`` reads (the others stay as the task's parameters hold them)."""
    return {k: w for k, w in weights.items()
            if (k == "aram_lambda" and cfg.aram is not None) or (k == "multipliers" and cfg.constraints)}


def aram_update(cfg: AramConfig, lam, metrics: dict):
    """lambda_ARAM once per epoch (design §5): when the epoch's success exceeds the gate,
    lambda <- clip(lambda + lr (clip099 - target), 0, lambda_max)."""
    ok = (metrics["success"] > cfg.success_gate) & (metrics["episodes"] > 0)
    return jnp.where(ok, jnp.clip(lam + cfg.lr * (metrics["clip099"] - cfg.target), 0.0, cfg.lambda_max), lam)


def multiplier_update(cfg: Constraint, lam, mean_cost):
    """A constraint's multiplier once per epoch, by dual ascent on the epoch's mean cost per step:
    lambda <- clip(lambda + lr (J_c - budget), 0, lambda_max)."""
    return jnp.clip(lam + cfg.lr * (mean_cost - cfg.budget), 0.0, cfg.lambda_max)


def update_weights(cfg: RewardConfig, weights: dict, metrics: dict, steps: dict) -> tuple[dict, dict]:
    """The adaptive weights after an epoch, and its metrics with each constraint's mean cost per step (from the
    rollout's per-step metrics ``steps``), each multiplier (``lambda_<measure>``) and ARAM's ``aram_lambda`` added.
    ``metrics`` holds the epoch's ``success``, ``episodes`` and ``clip099`` (ARAM's gate and signal)."""
    weights, metrics = dict(weights), dict(metrics)
    metrics |= {cost_metric(x): steps[cost_metric(x)].mean() for x in cfg.constraints}
    if cfg.constraints:
        weights["multipliers"] = jnp.stack([multiplier_update(x, weights["multipliers"][i], metrics[cost_metric(x)])
                                            for i, x in enumerate(cfg.constraints)])
        metrics |= {f"lambda_{x.measure}": weights["multipliers"][i] for i, x in enumerate(cfg.constraints)}
    if cfg.aram is not None:
        weights["aram_lambda"] = aram_update(cfg.aram, weights["aram_lambda"], metrics)
        metrics["aram_lambda"] = weights["aram_lambda"]
    return weights, metrics


def cost_metric(cfg: Constraint) -> str:
    """The name a constraint's per-step cost has among a step's metrics (its epoch mean in the training log)."""
    return f"{COST_PREFIX}{cfg.measure}"


def constraint_cost(cfg: Constraint, x: jnp.ndarray, passed: jnp.ndarray | bool = False) -> jnp.ndarray:
    """A constraint's per-step cost c_t from the step's measure ``x`` and whether the episode's measure passed the
    limit at an earlier step (``passed``, the peak cost's memory); its multiplier weighs it in r_t, its epoch mean
    moves the multiplier."""
    if cfg.cost == "rate":
        return (x > cfg.limit).astype(jnp.float32)
    if cfg.cost in PEAK_COSTS:
        return (passed | (x > cfg.limit)).astype(jnp.float32)
    return jnp.maximum(x - cfg.limit, 0.0) / cfg.limit


def ended_early_charge(cfg: RewardConfig, multipliers, costs, detach, success, left) -> jnp.ndarray:
    """What an episode that ends with ``left`` steps to its horizon still pays in r_t, per step left: a detached one,
    in the normalised Lagrangian, as past every limit (``config.LAGRANGIANS``); a successful one its ``horizon``
    constraints' costs as they stand (``config.COSTS``). ``costs``: this step's, in the config's order."""
    horizon = jnp.asarray([x.cost == "horizon" for x in cfg.constraints], jnp.float32)
    charge = success * jnp.dot(multipliers * horizon, costs)
    if cfg.lagrangian == "normalized":
        charge = charge + detach * multipliers.sum()
    return left * charge


def aram_penalty(cfg: AramConfig, lam, stall, d, action, q_resp, delta, revolute):
    """ARAM-lite (design §5): (r_aram, new stall count). ``q_resp`` = q_t - q_{t-K}; ``delta`` = q_goal - q_start."""
    normalized = jnp.abs(q_resp) / jnp.maximum(delta, 1e-6) < cfg.frac
    raw = jnp.abs(q_resp) < cfg.raw_eps
    low = {"raw": raw, "normalized": normalized, "joint_aware": jnp.where(revolute, raw, normalized)}[cfg.response]
    stall = jnp.where(low, stall + 1, 0)
    gate = (d < cfg.d_contact) & (jnp.linalg.norm(action) > cfg.action_norm) & (stall >= cfg.stall_steps)
    return -lam * gate * jnp.mean(action**2), stall


def reconfig_bonus(cfg: ReconfigConfig, cooldown, d_ring, q_ring, action, prev_action, hand_qd, delta, K: int):
    """Reconfig (design §5): (r_reconfig, new cooldown). Rings hold the last 2K+1 values of d and q, newest last."""
    d, q_resp, prev_resp = d_ring[-1], q_ring[-1] - q_ring[-1 - K], q_ring[-1 - K] - q_ring[0]
    contact = jnp.maximum(0.0, d_ring[-1 - K] - d)
    response = jnp.maximum(0.0, q_resp - prev_resp)
    slip = jnp.maximum(0.0, d_ring[: K + 1].max() - d_ring[-1 - K:].max())
    gate = ((d < cfg.d_contact) & (jnp.linalg.norm(action) > cfg.action_norm)
            & (jnp.abs(q_resp / jnp.maximum(delta, 1e-6)) < cfg.stall_frac) & (cooldown == 0)
            & (jnp.linalg.norm(action - prev_action) < cfg.max_action_change)
            & (jnp.linalg.norm(hand_qd) < cfg.max_hand_speed))
    bonus = gate * (cfg.w_contact * contact + cfg.w_response * response + cfg.w_slip * slip)
    return bonus, jnp.where(gate, cfg.cooldown, jnp.maximum(cooldown - 1, 0))
