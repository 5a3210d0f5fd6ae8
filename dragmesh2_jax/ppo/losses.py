"""PPO's pure pieces, Brax's ``losses.py`` manner: GAE and the loss as functions of arrays and parameters only.

Loss (paper eq. opt): L = L_PPO + c_v L_V + c_b L_bounds - c_e H + w_aux L_aux, with the clipped surrogate, the
clipped value loss in the normalised value space, rl_games' bounds loss on the action mean beyond +-bounds_at (1.1),
and the auxiliary loss in z-scored target space (design §6-§7); beyond the paper, + c_s L_smooth when ``smooth_coef`` is
set, the surrogate over the sampled actions alone when some worlds act on the mean (``mean_share``), and + c_d
L_distill, the teachers' labels, when the batch carries them (``distill_coef``). KL(old || new) is reported as rl_games
computes it.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from dragmesh2_jax.policies.gla import TokenWindows
from dragmesh2_jax.ppo.config import PPOConfig

LOG2PI = float(np.log(2 * np.pi))


@struct.dataclass
class Batch:
    state: jnp.ndarray  # normalised network inputs
    history: jnp.ndarray | TokenWindows  # the windows, or a rollout's windows sharing their tokens
    privileged: jnp.ndarray
    aux_target: jnp.ndarray  # z-scored auxiliary targets
    action: jnp.ndarray
    logp: jnp.ndarray
    mu: jnp.ndarray  # rollout-time action mean (for the exact KL)
    mu_prev: jnp.ndarray  # rollout-time action mean of the step before (the smoothness loss's target)
    prev_valid: jnp.ndarray  # 1 where that step is of the same episode and in this rollout
    log_std: jnp.ndarray
    explore: jnp.ndarray  # 1 where the action was sampled, 0 where a world acted on the mean (PPOConfig.mean_share)
    value: jnp.ndarray  # normalised value prediction at rollout time
    advantage: jnp.ndarray
    target: jnp.ndarray  # normalised return target
    teacher_mu: jnp.ndarray | None = None  # the teachers' labels (``ppo/distill.py``); None: not distilled
    taught: jnp.ndarray | None = None  # 1 where the step's object has a teacher

    def take(self, index: jnp.ndarray) -> Batch:
        """The samples at ``index`` (a minibatch)."""
        history = self.history.take(index) if isinstance(self.history, TokenWindows) else self.history[index]
        return jax.tree.map(lambda x: x[index], self.replace(history=None)).replace(history=history)


def gaussian_logp(a, mu, log_std):
    return jnp.sum(-0.5 * ((a - mu) / jnp.exp(log_std)) ** 2 - log_std - 0.5 * LOG2PI, axis=-1)


def compute_gae(rewards, values, dones, last_value, gamma: float, lam: float):
    """(advantages, returns) over (T, N) arrays; ``dones[t]`` ends the episode after step t."""

    def body(carry, x):
        adv_next, v_next = carry
        r, v, d = x
        nonterminal = 1.0 - d
        delta = r + gamma * v_next * nonterminal - v
        adv = delta + gamma * lam * nonterminal * adv_next
        return (adv, v), adv

    _, adv = jax.lax.scan(body, (jnp.zeros_like(last_value), last_value), (rewards, values, dones), reverse=True)
    return adv, adv + values


def compute_ppo_loss(params, apply: Callable, aux_head: Callable | None, batch: Batch, config: PPOConfig, w_aux,
                     axis: str | None = None, w_distill=0.0, active: jnp.ndarray | None = None):
    """(total loss, its terms) of a minibatch. ``apply(params, state, history, privileged) -> (mu, log_std, value,
    z_hist)``; ``aux_head(params, z_hist) -> prediction`` (None: no auxiliary loss). ``axis``: a mesh axis the
    minibatch is split over (equal shards): the advantages are normalised by the whole minibatch's moments (the
    terms stay this shard's means: the caller averages their gradients over the axis). ``active``: the action's
    channels that move something (None: all), the only ones the teachers' labels are matched on."""
    c = config
    mu, log_std, v, z = apply(params, batch.state, batch.history, batch.privileged)
    logp = gaussian_logp(batch.action, mu, log_std)
    ratio = jnp.exp(logp - batch.logp)
    adv = batch.advantage
    if c.normalize_advantage:
        if axis is None:
            adv = (adv - adv.mean()) / (adv.std() + 1e-8)
        else:
            mean = jax.lax.pmean(adv.mean(), axis)
            adv = (adv - mean) / (jnp.sqrt(jax.lax.pmean(jnp.mean((adv - mean) ** 2), axis)) + 1e-8)
    # the surrogate over the sampled actions only: a mean action says nothing of which way the policy should move
    surrogate = jnp.minimum(ratio * adv, jnp.clip(ratio, 1 - c.clip_eps, 1 + c.clip_eps) * adv)
    sampled, shards = jnp.sum(batch.explore), 1
    if axis is not None:  # the whole minibatch's mean once the caller averages the shards' gradients
        sampled, shards = jax.lax.psum(sampled, axis), jax.lax.psum(1, axis)
    pg = -shards * jnp.sum(batch.explore * surrogate) / jnp.maximum(sampled, 1.0)
    if c.clip_value:
        v_clip = batch.value + jnp.clip(v - batch.value, -c.clip_eps, c.clip_eps)
        vl = 0.5 * jnp.mean(jnp.maximum((v - batch.target) ** 2, (v_clip - batch.target) ** 2))
    else:
        vl = 0.5 * jnp.mean((v - batch.target) ** 2)
    bounds = jnp.mean(jnp.sum(jnp.maximum(jnp.abs(mu) - c.bounds_at, 0) ** 2, axis=-1))
    entropy = jnp.sum(log_std + 0.5 * (LOG2PI + 1.0))
    aux = jnp.float32(0.0)
    if aux_head is not None:
        pred = aux_head(params, z)
        aux = jnp.sum(jnp.asarray(c.aux_channel_weights) * jnp.mean((pred - batch.aux_target) ** 2, axis=0))
    total = pg + c.value_coef * vl + c.bounds_coef * bounds - c.entropy_coef * entropy + w_aux * aux
    terms = {}
    if batch.teacher_mu is not None:  # DAgger's labels on the student's own steps, where a teacher gives one
        live = jnp.ones(mu.shape[-1]) if active is None else jnp.asarray(active, mu.dtype)
        miss = jnp.sum(live * (mu - batch.teacher_mu) ** 2, axis=-1) / jnp.sum(live)
        terms["distill_loss"] = jnp.sum(batch.taught * miss) / jnp.maximum(jnp.sum(batch.taught), 1.0)
        total = total + w_distill * terms["distill_loss"]
    if c.smooth_coef > 0:
        change = jnp.mean((mu - batch.mu_prev) ** 2, axis=-1)
        terms["smooth_loss"] = jnp.sum(batch.prev_valid * change) / jnp.maximum(jnp.sum(batch.prev_valid), 1.0)
        total = total + c.smooth_coef * terms["smooth_loss"]
    kl = jnp.mean(jnp.sum(log_std - batch.log_std + (jnp.exp(2 * batch.log_std) + (batch.mu - mu) ** 2)
                          / (2 * jnp.exp(2 * log_std)) - 0.5, axis=-1))  # KL(old || new), as rl_games
    return total, {"loss": total, "policy_loss": pg, "value_loss": vl, "bounds_loss": bounds, "aux_loss": aux,
                   "kl": kl, "entropy": entropy, **terms}
