"""PPO's pure pieces (ppo/losses.py) against hand-computed values.

``compute_gae(rewards, values, dones, last_value, gamma, lam)`` cuts bootstrapping at every ``done``. The training
program represents a time-limit truncation as ``done`` plus ``gamma * V(final observation)`` added to that step's
reward; a termination is ``done`` alone. ``compute_ppo_loss`` is the clipped surrogate, the (clipped) value loss
``0.5 (v - target)^2``, the bounds loss on ``|mu| > 1.1``, the entropy of the diagonal Gaussian, and KL(old || new).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.ppo.losses import LOG2PI, Batch, compute_gae, compute_ppo_loss


def test_gae_by_hand_no_end_termination_truncation():
    """gamma = lam = 0.5, r = 1, V = (1, 2, 4), V(last) = 8; one column each: no episode end, a termination after
    step 1, a truncation after step 1 whose final observation is worth 6."""
    g = 0.5
    r = jnp.ones((3, 3)).at[1, 2].add(g * 6.0)  # the truncation's bootstrap, folded into its reward
    v = jnp.tile(jnp.array([[1.0], [2.0], [4.0]]), (1, 3))
    d = jnp.zeros((3, 3)).at[1, 1].set(1.0).at[1, 2].set(1.0)
    adv, ret = compute_gae(r, v, d, jnp.full(3, 8.0), gamma=g, lam=0.5)
    # deltas: column 0 (1, 1, 1); columns 1/2 at t=1: 1 - 2 = -1 / 1 + 3 - 2 = 2; adv(t) = delta(t) + 0.25 adv(t+1)
    np.testing.assert_allclose(np.asarray(adv), [[1.3125, 0.75, 1.5], [1.25, -1.0, 2.0], [1.0, 1.0, 1.0]])
    np.testing.assert_allclose(np.asarray(ret), np.asarray(adv) + np.asarray(v))


def _reference_gae(r, v, terminated, truncated, v_final, last_value, gamma, lam):
    """Textbook GAE with explicit episode ends: after a termination the next value is 0, after a truncation it is
    V(final observation); either way the advantage does not flow back across the end."""
    T, N = r.shape
    adv = np.zeros((T, N))
    for n in range(N):
        next_v, next_adv = last_value[n], 0.0
        for t in reversed(range(T)):
            if terminated[t, n]:
                next_v, next_adv = 0.0, 0.0
            elif truncated[t, n]:
                next_v, next_adv = v_final[t, n], 0.0
            adv[t, n] = r[t, n] + gamma * next_v - v[t, n] + gamma * lam * next_adv
            next_v, next_adv = v[t, n], adv[t, n]
    return adv, adv + v


def test_gae_several_episodes_in_one_rollout_matches_reference():
    """Several episodes end inside one rollout (terminations and truncations, adjacent ends, an end at the last
    step): the program's representation gives the textbook advantages and returns."""
    rng = np.random.default_rng(0)
    T, N, gamma, lam = 9, 3, 0.9, 0.8
    r, v, v_final = rng.normal(size=(T, N)), rng.normal(size=(T, N)), rng.normal(size=(T, N))
    last = rng.normal(size=N)
    term, trunc = np.zeros((T, N), bool), np.zeros((T, N), bool)
    term[[2, 6], 0], trunc[4, 0] = True, True
    trunc[[1, 2, 8], 1] = True
    term[8, 2], trunc[[0, 5], 2] = True, True
    want_adv, want_ret = _reference_gae(r, v, term, trunc, v_final, last, gamma, lam)
    adv, ret = compute_gae(jnp.asarray(r + gamma * v_final * trunc, jnp.float32), jnp.asarray(v, jnp.float32),
                           jnp.asarray(term | trunc, jnp.float32), jnp.asarray(last, jnp.float32), gamma, lam)
    np.testing.assert_allclose(np.asarray(adv), want_adv, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(np.asarray(ret), want_ret, rtol=1e-5, atol=1e-5)


# ------------------------------------------------------------------------------------------------- the loss
def _apply(params, state, history, privileged):
    """A 'network' whose outputs are its parameters: mu (B, A), the state-independent log_std (A,), value (B,)."""
    return params["mu"], params["log_std"], params["v"], None


def _setup(ratio, adv, mu=None, log_std=None, value_new=None, value_old=None, target=None, mu_prev=None,
           prev_valid=None, explore=None):
    """Parameters and a batch in which the new/old probability ratio of sample i is ``ratio[i]`` (the action is
    one standard deviation above the new mean in every dimension)."""
    ratio = np.asarray(ratio, np.float32)
    B = len(ratio)
    mu = jnp.zeros((B, 1)) if mu is None else jnp.asarray(mu, jnp.float32)
    log_std = jnp.zeros(mu.shape[1]) if log_std is None else jnp.asarray(log_std, jnp.float32)
    action = mu + jnp.exp(log_std)
    logp_new = jnp.sum(-0.5 - log_std - 0.5 * LOG2PI) * jnp.ones(B)
    zeros = jnp.zeros(B)
    params = {"mu": mu, "log_std": log_std, "v": zeros if value_new is None else jnp.asarray(value_new, jnp.float32)}
    batch = Batch(state=jnp.zeros((B, 1)), history=jnp.zeros((B, 1, 1)), privileged=jnp.zeros((B, 1)),
                  aux_target=jnp.zeros((B, 1)), action=action, logp=logp_new - jnp.log(ratio), mu=mu,
                  mu_prev=mu if mu_prev is None else jnp.asarray(mu_prev, jnp.float32),
                  prev_valid=jnp.ones(B) if prev_valid is None else jnp.asarray(prev_valid, jnp.float32),
                  log_std=jnp.broadcast_to(log_std, mu.shape),
                  explore=jnp.ones(B) if explore is None else jnp.asarray(explore, jnp.float32),
                  value=zeros if value_old is None else value_old,
                  advantage=jnp.asarray(adv, jnp.float32), target=zeros if target is None else target)
    return params, batch


PLAIN = dict(normalize_advantage=False, value_coef=0.0, bounds_coef=0.0, entropy_coef=0.0, clip_eps=0.2)
#: ratio / advantage of each sample: inside the clip range (2), beyond it with each sign of the advantage (4)
RATIO = [1.1, 0.9, 1.5, 1.5, 0.5, 0.5]
ADV = [2.0, -1.0, 1.0, -1.0, 1.0, -1.0]


def _loss(params, batch, **config):
    return compute_ppo_loss(params, _apply, None, batch, PPOConfig(**{**PLAIN, **config}), 0.0)


def test_surrogate_inside_the_clip_range_is_minus_mean_ratio_times_advantage():
    _, info = _loss(*_setup(RATIO[:2], ADV[:2]))
    assert float(info["policy_loss"]) == pytest.approx(-(1.1 * 2.0 - 0.9 * 1.0) / 2, rel=1e-5)
    assert float(info["kl"]) == pytest.approx(0.0, abs=1e-6)  # same mean and std as at rollout time


def test_surrogate_takes_the_pessimistic_branch_outside_the_clip_range():
    """min(r A, clip(r) A): (1.5, +1) -> 1.2 and (0.5, -1) -> -0.8 (clipped); (1.5, -1) -> -1.5 and (0.5, +1) -> 0.5
    (unclipped); with the two inside samples 2.2 and -0.9 the mean is 0.7 / 6."""
    for r, a, want in zip(RATIO, ADV, [2.2, -0.9, 1.2, -1.5, 0.5, -0.8], strict=True):
        _, info = _loss(*_setup([r], [a]))
        assert float(info["policy_loss"]) == pytest.approx(-want, rel=1e-5), (r, a)
    total, info = _loss(*_setup(RATIO, ADV))
    assert float(info["policy_loss"]) == pytest.approx(-0.7 / 6, rel=1e-5)
    assert float(total) == pytest.approx(-0.7 / 6, rel=1e-5)  # every other coefficient is 0


def test_no_gradient_through_a_sample_clipped_in_the_direction_of_its_advantage():
    """d(-r A / B)/d mu = -(r A / B) d logp/d mu, and d logp/d mu = (a - mu) / std^2 = 1 here; the samples with ratio
    1.5 and A > 0, and ratio 0.5 and A < 0, are clipped and get no gradient."""
    params, batch = _setup(RATIO, ADV)
    grads, _ = jax.grad(_loss, has_aux=True)(params, batch)
    want = -np.asarray(RATIO) * np.asarray(ADV) / 6 * np.array([1, 1, 0, 1, 1, 0])
    np.testing.assert_allclose(np.asarray(grads["mu"])[:, 0], want, rtol=1e-5, atol=1e-7)


def test_the_surrogate_is_over_the_sampled_actions_alone():
    """Samples of worlds that acted on the mean (explore 0) neither enter the surrogate's mean nor get its gradient:
    with the last four of RATIO/ADV so marked, the loss is the first two's, (2.2 - 0.9) / 2."""
    explore = [1, 1, 0, 0, 0, 0]
    params, batch = _setup(RATIO, ADV, explore=explore)
    _, info = _loss(params, batch)
    assert float(info["policy_loss"]) == pytest.approx(-(2.2 - 0.9) / 2, rel=1e-5)
    grads, _ = jax.grad(_loss, has_aux=True)(params, batch)
    want = -np.asarray(RATIO) * np.asarray(ADV) / 2 * np.asarray(explore)
    np.testing.assert_allclose(np.asarray(grads["mu"])[:, 0], want, rtol=1e-5, atol=1e-7)


def test_the_smoothness_loss_is_the_mean_squared_change_of_the_action_mean_over_consecutive_steps_of_an_episode():
    """Means (0, 0), (1, 1), (2, 0) after (0, 0), (0, 0), (0, 2) with the third a fresh episode's first step: the
    loss is mean((0, 1)) = 0.5 (the third pair not counted), weighed by smooth_coef in the total; its gradient pulls
    the mean back towards the step before's; with smooth_coef 0 no term at all."""
    setup = _setup([1.0] * 3, [0.0] * 3, mu=[[0, 0], [1, 1], [2, 0]], mu_prev=[[0, 0], [0, 0], [0, 2]],
                   prev_valid=[1, 1, 0])
    total, info = _loss(*setup, smooth_coef=0.3)
    assert float(info["smooth_loss"]) == pytest.approx(0.5) and float(total) == pytest.approx(0.3 * 0.5)
    grads, _ = jax.grad(_loss, has_aux=True)(*setup, smooth_coef=0.3)
    np.testing.assert_allclose(np.asarray(grads["mu"]), 0.3 * np.array([[0, 0], [1, 1], [0, 0]]) / 2, rtol=1e-5)
    assert "smooth_loss" not in _loss(*setup)[1]


def test_the_label_loss_is_the_mean_squared_miss_over_the_taught_steps():
    """Means (0, 0), (1, 1), (2, 0) against the teachers' (1, 1), (5, 5), (0, 0), the second step untaught: the loss is
    mean(1, 2) = 1.5 (the untaught miss not counted), weighed by w_distill in the total; the untaught step gets no
    gradient; a batch without labels has no such term."""
    params, batch = _setup([1.0] * 3, [0.0] * 3, mu=[[0, 0], [1, 1], [2, 0]])
    taught = batch.replace(teacher_mu=jnp.array([[1.0, 1.0], [5.0, 5.0], [0.0, 0.0]]), taught=jnp.array([1.0, 0, 1]))
    loss = lambda p, b: compute_ppo_loss(p, _apply, None, b, PPOConfig(**PLAIN), 0.0, w_distill=0.4)  # noqa: E731
    total, info = loss(params, taught)
    assert float(info["distill_loss"]) == pytest.approx(1.5) and float(total) == pytest.approx(0.4 * 1.5)
    grads, _ = jax.grad(loss, has_aux=True)(params, taught)
    np.testing.assert_allclose(np.asarray(grads["mu"]), 0.4 * np.array([[-1, -1], [0, 0], [2, 0]]) / 2, rtol=1e-5)
    assert "distill_loss" not in loss(params, batch)[1]
    # matched on the channels that move something: the second channel locked, only the first's misses count
    locked = compute_ppo_loss(params, _apply, None, taught, PPOConfig(**PLAIN), 0.0, w_distill=0.4,
                              active=jnp.array([True, False]))[1]
    assert float(locked["distill_loss"]) == pytest.approx((1 + 4) / 2)


def test_advantage_normalisation_uses_the_minibatch_mean_and_std():
    """Advantages (3, 1) normalise to (1, -1) (population std); ratios (1.1, 1): the loss is -(1.1 - 1) / 2."""
    _, info = _loss(*_setup([1.1, 1.0], [3.0, 1.0]), normalize_advantage=True)
    assert float(info["policy_loss"]) == pytest.approx(-0.05, rel=1e-4)


def test_value_loss_clipped_and_plain():
    """Old prediction 0, target 1, clip 0.2: a new prediction 0.5 is clipped to 0.2, loss max(0.25, 0.64) = 0.64; a
    new prediction -0.1 is within the clip, loss 1.21. Clipped 0.5 mean(0.64, 1.21); plain 0.5 mean(0.25, 1.21)."""
    kw = dict(value_new=[0.5, -0.1], target=jnp.ones(2))
    _, info = _loss(*_setup([1.0, 1.0], [0.0, 0.0], **kw), clip_value=True)
    assert float(info["value_loss"]) == pytest.approx(0.4625, rel=1e-5)
    _, info = _loss(*_setup([1.0, 1.0], [0.0, 0.0], **kw), clip_value=False)
    assert float(info["value_loss"]) == pytest.approx(0.365, rel=1e-5)


def test_entropy_bounds_kl_and_the_weighted_total():
    """log_std (0, -1): entropy = sum(log_std + (log 2pi + 1) / 2) = log 2pi. mu (1.6, -1.3) with bound 1.1: bounds
    0.5^2 + 0.2^2 = 0.29. Old mean 1 below the new one in dimension 0, same std: KL(old || new) = 0.5.
    total = pg + 2 vl + 0.5 bounds - 0.1 entropy."""
    params, batch = _setup([1.0], [1.0], mu=[[1.6, -1.3]], log_std=[0.0, -1.0], value_new=[0.0], target=jnp.ones(1))
    batch = batch.replace(mu=batch.mu.at[0, 0].add(-1.0))
    total, info = _loss(params, batch, value_coef=2.0, bounds_coef=0.5, entropy_coef=0.1, clip_value=False)
    assert float(info["entropy"]) == pytest.approx(LOG2PI, rel=1e-5)
    assert float(info["bounds_loss"]) == pytest.approx(0.29, rel=1e-5)
    assert float(info["kl"]) == pytest.approx(0.5, rel=1e-5)
    assert float(info["policy_loss"]) == pytest.approx(-1.0, rel=1e-5)
    assert float(info["value_loss"]) == pytest.approx(0.5, rel=1e-5)
    assert float(total) == pytest.approx(-1.0 + 2 * 0.5 + 0.5 * 0.29 - 0.1 * LOG2PI, rel=1e-5)
    # bounds_at 0.9 below the action bound: the same mean pays (1.6 - 0.9)^2 + (1.3 - 0.9)^2 = 0.65
    _, info = _loss(params, batch, bounds_coef=0.5, bounds_at=0.9, clip_value=False)
    assert float(info["bounds_loss"]) == pytest.approx(0.65, rel=1e-5)
