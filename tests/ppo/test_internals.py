"""Training internals: the running normaliser and the KL-adaptive learning rate.

``RunningStats`` (policies/normalize.py) starts from mean 0, var 1 with a pseudo-count of 1e-4 and merges batches
by the parallel algorithm, so after batches totalling N samples its mean and (population) variance are those of the
concatenation up to a weight of 1e-4 / N; ``normalize`` is ``clip((x - mean) / sqrt(var + 1e-5), -clip, clip)``.

The adaptive learning rate (rl_games, ``lr_schedule="adaptive"``) moves once per update epoch on that epoch's last
minibatch KL: above ``2 kl_threshold`` it is divided by 1.5, below ``kl_threshold / 2`` multiplied by 1.5, and kept
within [1e-6, 1e-2]. The rule lives inside ``ppo.train.epoch``, so it is checked through one epoch of the tiny
point-mass task with one update epoch of one minibatch (the reported KL is then the one the rule saw).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.policies.networks import NetworkConfig
from dragmesh2_jax.policies.normalize import RunningStats
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.ppo.train import epoch_jit, init_jit, make_train
from tests.ppo.test_ppo import PointMass


def test_running_stats_merge_batches_like_their_concatenation():
    rng = np.random.default_rng(0)
    batches = [rng.normal(3.0, 2.0, (5, 3)), rng.normal(-1.0, 0.5, (2, 4, 3)), rng.normal(10.0, 1.0, (1, 3))]
    s = RunningStats.create(3)
    assert np.asarray(s.mean).tolist() == [0, 0, 0] and np.asarray(s.var).tolist() == [1, 1, 1]
    for b in batches:
        s = s.update(jnp.asarray(b, jnp.float32))
    allx = np.concatenate([b.reshape(-1, 3) for b in batches])
    assert float(s.count) == pytest.approx(len(allx) + 1e-4)
    np.testing.assert_allclose(np.asarray(s.mean), allx.mean(0), rtol=1e-4, atol=1e-4)
    np.testing.assert_allclose(np.asarray(s.var), allx.var(0), rtol=1e-4, atol=1e-4)
    # the same samples in one batch give the same statistics
    one = RunningStats.create(3).update(jnp.asarray(allx, jnp.float32))
    np.testing.assert_allclose(np.asarray(one.mean), np.asarray(s.mean), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(np.asarray(one.var), np.asarray(s.var), rtol=1e-5, atol=1e-5)


def test_running_stats_normalize_a_batch():
    """mean (1, -2), var (4, 0.25): (3, -2) -> (1, 0); (100, -3) -> (5 clipped, -2); clip 1.5 -> (1.5, -1.5)."""
    s = RunningStats(mean=jnp.array([1.0, -2.0]), var=jnp.array([4.0, 0.25]), count=jnp.asarray(10.0))
    x = jnp.array([[3.0, -2.0], [100.0, -3.0]])
    np.testing.assert_allclose(np.asarray(s.normalize(x)), [[1.0, 0.0], [5.0, -2.0]], rtol=1e-4)
    np.testing.assert_allclose(np.asarray(s.normalize(x, clip=1.5)), [[1.0, 0.0], [1.5, -1.5]], rtol=1e-4)


@pytest.fixture(scope="module")
def lr_after_one_epoch():
    """``(kl_threshold, lr before) -> (lr after, the KL the rule saw)`` for one epoch of the point-mass task."""
    net = NetworkConfig(encoder="none", state_sizes=(8,), log_std_init=-1.0)
    programs = {}

    def run(kl_threshold: float, lr: float):
        cfg = PPOConfig(num_envs=2, rollout_len=4, update_epochs=1, num_minibatches=1, lr_schedule="adaptive",
                        kl_threshold=kl_threshold, lr=1e-3)
        p = programs.setdefault(kl_threshold, make_train(PointMass(), net, cfg, "state_only"))
        ts = init_jit(p, p.task.data, jax.random.PRNGKey(0)).replace(lr=jnp.float32(lr))
        ts, m = epoch_jit(p, p.task.data, ts)
        assert float(m["lr"]) == float(ts.lr)
        return float(ts.lr), float(m["kl"])

    return run


def test_adaptive_lr_rises_when_kl_is_low_up_to_its_bound(lr_after_one_epoch):
    lr, kl = lr_after_one_epoch(1.0, 1e-3)
    assert kl < 0.5  # below kl_threshold / 2
    assert lr == pytest.approx(1.5e-3, rel=1e-6)
    assert lr_after_one_epoch(1.0, 8e-3)[0] == pytest.approx(1e-2, rel=1e-6)  # 1.2e-2 clipped


def test_adaptive_lr_falls_when_kl_is_high_down_to_its_bound(lr_after_one_epoch):
    """A negative threshold makes every KL (>= 0) exceed twice it."""
    assert lr_after_one_epoch(-1.0, 1e-3)[0] == pytest.approx(1e-3 / 1.5, rel=1e-6)
    assert lr_after_one_epoch(-1.0, 1.2e-6)[0] == pytest.approx(1e-6, rel=1e-6)  # 8e-7 clipped
