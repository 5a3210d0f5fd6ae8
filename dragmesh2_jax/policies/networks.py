"""Actor-critic networks (paper Appendix A.3, Table 8; design §6).

Two branches: the state s_t through an MLP [512, 512, 256] (ELU); the history block H_t (16 tokens of 102)
through a temporal encoder to a 128-d contact-history feature z_hist, LayerNorm'd. The fused features give
the Gaussian mean (51) and the value. The auxiliary head (128 -> 64 -> 4) reads z_hist only. Every linear map
starts as the reference's do (PyTorch's ``nn.Linear`` initialisation, ``policies/init.py``).

Temporal encoders: ``gla`` (PICA), ``flat`` (flattened history MLP), ``gru``, ``transformer`` (causal,
1 block), or ``none`` (state-only PPO). The aux targets are not an input of any of them (``ActorCritic``
only ever receives ``obs.state``, ``obs.history`` and ``obs.privileged``).

Critic: ``shared`` (the paper: value head on the actor's fused features) or ``privileged`` (beyond the paper,
an asymmetric critic as in MuJoCo Playground's LEAP hand: its own MLP on [s_t, privileged], where privileged =
damping and friction multipliers and the contact load; the actor never sees them).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, get_args

import flax.linen as nn
import jax
import jax.numpy as jnp

from dragmesh2_jax.assets.hand import NUM_DOFS
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.policies.controller import Policy
from dragmesh2_jax.policies.gla import GatedLinearAttention, TokenWindows
from dragmesh2_jax.policies.init import TORCH_LINEAR_INIT, Dense
from dragmesh2_jax.task.protocol import Obs

Encoder = Literal["none", "flat", "gla", "gru", "transformer"]
Critic = Literal["shared", "privileged"]
ENCODERS, CRITICS = get_args(Encoder), get_args(Critic)


@dataclass(frozen=True)
class NetworkConfig:
    """The actor-critic: its temporal encoder, its critic and its sizes (paper Table 8; design §6)."""

    encoder: Encoder = "gla"
    """the history's temporal encoder (none: state-only)"""
    critic: Critic = "shared"
    """the value head's input: the actor's features (shared), or privileged ones"""
    state_sizes: tuple[int, ...] = (512, 512, 256)
    """the state MLP"""
    hist_dim: int = 128
    """z_hist"""
    heads: int = 4
    """GLA / attention heads"""
    log_std_init: float = -2.0
    """the state-independent log std (std 0.135)"""
    critic_sizes: tuple[int, ...] = (512, 256)
    """the privileged critic's MLP"""

    def __post_init__(self):
        if self.encoder not in ENCODERS:
            raise DragMeshError(f"unknown temporal encoder {self.encoder!r} (choose from {', '.join(ENCODERS)})")
        if self.critic not in CRITICS:
            raise DragMeshError(f"unknown critic {self.critic!r} (choose from {', '.join(CRITICS)})")
        if min((*self.state_sizes, *self.critic_sizes, self.hist_dim, self.heads), default=1) < 1:
            raise DragMeshError(f"network sizes and heads must be >= 1, got state_sizes {self.state_sizes}, "
                                f"critic_sizes {self.critic_sizes}, hist_dim {self.hist_dim}, heads {self.heads}")
        if not math.isfinite(self.log_std_init):
            raise DragMeshError(f"log_std_init must be finite, got {self.log_std_init}")


class MLP(nn.Module):
    sizes: Sequence[int]

    @nn.compact
    def __call__(self, x):
        for n in self.sizes:
            x = nn.elu(Dense(n)(x))
        return x


class TemporalEncoder(nn.Module):
    """H (..., L, 102) -> z_hist (..., dim); H may be ``TokenWindows`` (a rollout's windows sharing their tokens)."""

    kind: str = "gla"
    dim: int = 128
    heads: int = 4

    @nn.compact
    def __call__(self, history):
        if self.kind == "flat":
            if isinstance(history, TokenWindows):
                history = history.materialize()
            x = history.reshape(*history.shape[:-2], -1)
            return nn.LayerNorm(name="hist_norm")(MLP((256, self.dim))(x))
        token_proj = Dense(self.dim, name="token_proj")
        if self.kind == "gla":  # the last token's output only (closed form), token_proj folded into the layer
            token_proj(history.last() if isinstance(history, TokenWindows) else history[..., -1, :])  # its parameters
            proj = token_proj.variables["params"]
            gla = GatedLinearAttention(hidden=self.dim, heads=self.heads)
            return nn.LayerNorm(name="hist_norm")(gla(history, (proj["kernel"], proj["bias"])))
        if isinstance(history, TokenWindows):
            history = history.materialize()  # the other encoders read every window whole
        x = token_proj(history)
        if self.kind == "gru":
            cell = nn.GRUCell(features=self.dim, kernel_init=TORCH_LINEAR_INIT,
                              recurrent_kernel_init=TORCH_LINEAR_INIT)
            x = nn.RNN(cell)(x.reshape(-1, *x.shape[-2:])).reshape(x.shape)
        elif self.kind == "transformer":
            # one causal pre-LN block; only the last token's output is used, and under the causal mask it
            # attends to every token: so only its query, residual and MLP are computed
            L = x.shape[-2]
            x = x + self.param("pos", nn.initializers.normal(0.02), (L, self.dim))
            h = nn.LayerNorm()(x)
            attention = nn.MultiHeadDotProductAttention(num_heads=self.heads, kernel_init=TORCH_LINEAR_INIT)
            last = x[..., -1:, :] + attention(h[..., -1:, :], h)
            x = last + Dense(self.dim)(MLP((2 * self.dim,))(nn.LayerNorm()(last)))
        else:
            raise ValueError(f"unknown temporal encoder {self.kind!r}")
        return nn.LayerNorm(name="hist_norm")(x[..., -1, :])  # the last token's output


class ActorCritic(nn.Module):
    config: NetworkConfig = NetworkConfig()
    action_size: int = NUM_DOFS
    aux_size: int = 4

    def setup(self):
        c = self.config
        self.state_mlp = MLP(c.state_sizes)
        if c.encoder != "none":
            self.temporal = TemporalEncoder(c.encoder, c.hist_dim, c.heads)
        self.mu = Dense(self.action_size)
        if c.critic == "privileged":
            self.critic_mlp = MLP(c.critic_sizes)
        self.value = Dense(1)
        self.log_std = self.param("log_std", nn.initializers.constant(c.log_std_init), (self.action_size,))
        self.aux_head = MLP((64,))
        self.aux_out = Dense(self.aux_size)

    def features(self, state, history):
        z = self.state_mlp(state)
        if self.config.encoder == "none":
            return z, None
        h = self.temporal(history)
        return jnp.concatenate([z, h], axis=-1), h

    def __call__(self, state, history, privileged):
        """-> (action mean (51), log std (51), value (), z_hist or None)."""
        fused, h = self.features(state, history)
        privileged_critic = self.config.critic == "privileged"
        v_in = self.critic_mlp(jnp.concatenate([state, privileged], -1)) if privileged_critic else fused
        return self.mu(fused), self.log_std, self.value(v_in)[..., 0], h

    def actor(self, state, history):
        """-> (action mean (51), log std (51)): the policy alone (no critic, no privileged input)."""
        fused, _ = self.features(state, history)
        return self.mu(fused), self.log_std

    def aux(self, z_hist):
        """Auxiliary prediction of y_t from the contact-history feature alone."""
        return self.aux_out(self.aux_head(z_hist))

    def init_all(self, state, history, privileged):
        """Initialise every parameter, the aux head included."""
        _, _, _, h = self(state, history, privileged)
        return self.aux(h if h is not None else jnp.zeros((*state.shape[:-1], self.config.hist_dim)))


def make_inference_fn(net: ActorCritic, normalize_obs: bool):
    """Brax's ``make_inference_fn``: ``make_policy(deterministic) -> policy(params, obs, key) -> action``, the
    Gaussian mean (det) or a sample (stoch). ``params`` = {"net", "state_stats", "token_stats"}: the network and
    the observation normalisers; the policy reads obs.state and obs.history only."""

    def make_policy(deterministic: bool = True) -> Policy:
        def policy(params, obs: Obs, key):
            s, h = obs.state, obs.history
            if normalize_obs:
                s, h = params["state_stats"].normalize(s), params["token_stats"].normalize(h)
            mu, log_std = net.apply(params["net"], s, h, method=ActorCritic.actor)
            if deterministic:
                return mu
            return mu + jnp.exp(log_std) * jax.random.normal(key, mu.shape)

        return policy

    return make_policy
