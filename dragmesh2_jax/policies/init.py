"""How the networks' linear maps start: as PyTorch's ``nn.Linear`` does, which is what the reference's networks
use (rl_games' "default" initialiser leaves PyTorch's in place, GLA's linears included; every bias zeroed;
design §6). PyTorch draws a kernel from U(-1/sqrt(fan_in), 1/sqrt(fan_in)) (kaiming_uniform with a = sqrt(5)): variance
1/(3 fan_in), a third of flax's default lecun_normal. With flax's default the initial action means are 2x (history
encoders) to 7x (state-only MLP) larger, and PPO starts, and stays, at the action bounds
(results/archive.md, part 1 §14)."""

from __future__ import annotations

import functools

import flax.linen as nn

TORCH_LINEAR_INIT = nn.initializers.variance_scaling(1.0 / 3.0, "fan_in", "uniform")

#: ``nn.Dense`` with the reference's initialisation (bias zero, as flax's default).
Dense = functools.partial(nn.Dense, kernel_init=TORCH_LINEAR_INIT)
