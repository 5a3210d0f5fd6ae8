"""The fine-tunes' reward terms (design §5): ARAM's stall gate and Reconfig's bonus and cooldown."""

import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.task.config import AramConfig, ReconfigConfig
from dragmesh2_jax.task.rewards import aram_penalty, reconfig_bonus


def test_aram_penalises_large_actions_only_after_a_stall():
    cfg = AramConfig()
    a = jnp.full(51, 0.5)  # ||a|| = 3.6 > 1
    stall, pens = jnp.int32(0), []
    for _ in range(6):
        pen, stall = aram_penalty(cfg, 0.5, stall, 0.05, a, 0.0, 0.3, revolute=False)
        pens.append(float(pen))
    assert pens[:4] == [0.0] * 4 and pens[4] == pytest.approx(-0.5 * 0.25)  # gate opens at stall >= 5
    pen, stall = aram_penalty(cfg, 0.5, stall, 0.05, a, 0.02, 0.3, revolute=False)  # the joint moved
    assert float(pen) == 0.0 and int(stall) == 0


def test_reconfig_rewards_regained_contact_then_cools_down():
    cfg, K = ReconfigConfig(), 5
    # d over the last 2K+1 steps: slipping (0.095 -> 0.09), then contact regained (0.09 -> 0.05)
    d = jnp.asarray(np.r_[np.full(K, 0.095), 0.09, np.linspace(0.08, 0.05, K)], jnp.float32)
    q = jnp.zeros(2 * K + 1)
    a = jnp.full(51, 0.3)
    bonus, cooldown = reconfig_bonus(cfg, jnp.int32(0), d, q, a, a, jnp.zeros(51), 0.3, K)
    assert float(bonus) == pytest.approx(0.2 * 0.04 + 0.5 * 0.005, rel=1e-3) and int(cooldown) == cfg.cooldown
    bonus, cooldown = reconfig_bonus(cfg, cooldown, d, q, a, a, jnp.zeros(51), 0.3, K)
    assert float(bonus) == 0.0 and int(cooldown) == cfg.cooldown - 1
