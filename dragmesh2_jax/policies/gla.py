"""Gated Linear Attention (Yang et al., ICML 2024) in JAX, as the fla ``GatedLinearAttention`` layer the
reference uses (design §6): hidden 128, 4 heads, expand_k 0.5 (key dim 16 per head), expand_v 1 (value dim 32
per head), low-rank gate (rank 16) with log-sigmoid / 16, output gate swish(g_proj x), per-head RMSNorm,
no short convolution; run from a zero state over the whole token window.

Recurrence per head:  S_t = diag(exp(g_t)) S_{t-1} + k_t^T v_t,   o_t = (q_t / sqrt(d_k)) S_t.

The policy reads only the last token's output, so the layer computes just o_T, in closed form:
S_T = sum_t diag(exp(G_T - G_t)) k_t^T v_t with G_t = sum_{s<=t} g_s, hence
o_T = sum_t [sum_k q_T,k exp(G_T,k - G_t,k) k_t,k] v_t: two einsums, no scan over time. Every decay factor is
<= 1 (g <= 0), so the form is as stable as the recurrence. ``gla_recurrent`` keeps the full recurrence as the
specification the closed form is tested against.
"""

from __future__ import annotations

import flax.linen as nn
import jax
import jax.numpy as jnp
from flax import struct

from dragmesh2_jax.policies.init import TORCH_LINEAR_INIT, Dense


@struct.dataclass
class TokenWindows:
    """History windows that share their tokens. A rollout's consecutive observations of one world hold the same tokens
    shifted by one, so a batch of T x N windows of L tokens holds only N (L + T - 1) distinct ones: each world's token
    stream, a window a slice of it, where the tokens older than the window's episode are the zero token a reset
    writes. A layer that maps every token linearly (GLA's key, value and gate projections) maps each distinct token
    once: the same numbers as on the windows themselves (``materialize``), at a fraction of the work.

    stream (E, L + T - 1, D): each world's tokens (normalised); world, start (B,): a window's world and where it starts
    in that stream; valid (B, L): its tokens of its own episode; zero (D,): the zero token, normalised."""

    stream: jnp.ndarray
    world: jnp.ndarray
    start: jnp.ndarray
    valid: jnp.ndarray
    zero: jnp.ndarray

    @classmethod
    def of_rollout(cls, history: jnp.ndarray, done: jnp.ndarray, normalize) -> TokenWindows:
        """The windows of a rollout's observations, flattened time-major (sample k = t N + n, as the batch):
        ``history`` (T, N, L, D) raw tokens, ``done`` (T, N) the episode ended at step t (so observation t + 1
        began a new one), ``normalize`` the token normaliser."""
        T, N, L, _ = history.shape
        stream = jnp.concatenate([history[0], jnp.moveaxis(history[1:, :, -1], 0, 1)], axis=1)  # (N, L + T - 1, D)
        t = jnp.arange(T)[:, None]
        began = jnp.concatenate([jnp.zeros((1, N), bool), done[:-1] > 0], axis=0)  # observation t is a reset's
        # the step the window's episode began (its first observation), or none within the rollout: -L
        first = jax.lax.cummax(jnp.where(began, t, -L), axis=0)
        valid = (t[..., None] + jnp.arange(L) >= L - 1 + first[..., None]).reshape(T * N, L)
        world = jnp.tile(jnp.arange(N), T)
        start = jnp.repeat(jnp.arange(T), N)
        return cls(normalize(stream), world, start, valid, normalize(jnp.zeros(history.shape[-1], history.dtype)))

    @property
    def length(self) -> int:
        return self.valid.shape[-1]

    def take(self, index: jnp.ndarray) -> TokenWindows:
        """The windows at ``index`` (a minibatch): the streams stay whole."""
        return self.replace(world=self.world[index], start=self.start[index], valid=self.valid[index])

    def last(self) -> jnp.ndarray:
        """Each window's newest token (B, D)."""
        return self.stream[self.world, self.start + self.length - 1]

    def _windows(self, stream: jnp.ndarray, zero: jnp.ndarray) -> jnp.ndarray:
        windows = stream[self.world[:, None], self.start[:, None] + jnp.arange(self.length)]
        return jnp.where(self.valid[..., None], windows, zero)

    def project(self, W: jnp.ndarray, b: jnp.ndarray) -> jnp.ndarray:
        """``token @ W + b`` for every token of every window (B, L, n), each distinct token mapped once."""
        return self._windows(self.stream @ W + b, self.zero @ W + b)

    def materialize(self) -> jnp.ndarray:
        """The windows as arrays (B, L, D): what the batch would hold without sharing."""
        return self._windows(self.stream, self.zero)


def gla_recurrent(q, k, v, g, state0=None):
    """Gated linear attention by ``lax.scan`` over time.

    q, k, g: (..., T, H, dk) (q already scaled; g = log decay <= 0); v: (..., T, H, dv).
    Returns outputs (..., T, H, dv) and the final state (..., H, dk, dv)."""
    *batch, T, H, dk = q.shape
    dv = v.shape[-1]
    S0 = jnp.zeros((*batch, H, dk, dv), q.dtype) if state0 is None else state0
    move = lambda x: jnp.moveaxis(x, -3, 0)  # noqa: E731  time first

    def step(S, inp):
        qt, kt, vt, gt = inp
        S = S * jnp.exp(gt)[..., None] + kt[..., :, None] * vt[..., None, :]
        return S, jnp.einsum("...hk,...hkv->...hv", qt, S)

    S, o = jax.lax.scan(step, S0, (move(q), move(k), move(v), move(g)))
    return jnp.moveaxis(o, 0, -3), S


def gla_last(q_last, k, v, g):
    """The last token's output of gated linear attention, in closed form (no scan).

    q_last: (..., H, dk) (already scaled); k, g: (..., T, H, dk); v: (..., T, H, dv). Returns (..., H, dv),
    equal to ``gla_recurrent(q, k, v, g)[0][..., -1, :, :]``."""
    G = jnp.cumsum(g, axis=-3)
    decay = jnp.exp(G[..., -1:, :, :] - G)  # (..., T, H, dk): prod_{s=t+1..T} exp(g_s), each <= 1
    attn = jnp.einsum("...hk,...thk->...th", q_last, decay * k)
    return jnp.einsum("...th,...thv->...hv", attn, v)


class _Kernel(nn.Module):
    """A bias-free linear map's kernel, under the parameter names of ``nn.Dense`` (so the tree is unchanged)."""

    shape: tuple[int, int]

    @nn.compact
    def __call__(self):
        return self.param("kernel", TORCH_LINEAR_INIT, self.shape)


class GatedLinearAttention(nn.Module):
    hidden: int = 128
    heads: int = 4
    expand_k: float = 0.5
    expand_v: float = 1.0
    gate_rank: int = 16
    gate_normalizer: float = 16.0
    norm_eps: float = 1e-5

    @nn.compact
    def __call__(self, x, proj=None):
        """x: (..., T, hidden) -> the last token's output (..., hidden).

        With ``proj = (kernel, bias)`` of a linear input projection, ``x`` is the raw tokens (..., T, d_in) and the
        projection is folded into the key, value and gate weights (x W_p W_k = x (W_p W_k)): per token a product
        with d_in x (dk + dv + rank) weights instead of d_in x hidden and then hidden x (dk + dv + rank). ``x`` may be
        :class:`TokenWindows` (with ``proj``): each distinct token is then projected once."""
        H = self.heads
        dk, dv = int(self.hidden * self.expand_k), int(self.hidden * self.expand_v)
        hk, hv = dk // H, dv // H
        split = lambda y, d: y.reshape(*y.shape[:-1], H, d)  # noqa: E731
        if proj is None:
            tokens = lambda W: x @ W  # noqa: E731
            last = x[..., -1, :]
        elif isinstance(x, TokenWindows):
            W_in, b_in = proj
            tokens = lambda W: x.project(W_in @ W, b_in @ W)  # noqa: E731
            last = x.last() @ W_in + b_in
        else:
            W_in, b_in = proj
            tokens = lambda W: x @ (W_in @ W) + b_in @ W  # noqa: E731
            last = x[..., -1, :] @ W_in + b_in
        kernel = lambda name, n: _Kernel((self.hidden, n), name=name)()  # noqa: E731
        q = split(Dense(dk, use_bias=False, name="q_proj")(last), hk) * hk**-0.5
        k = split(tokens(kernel("k_proj", dk)), hk)
        v = split(tokens(kernel("v_proj", dv)), hv)
        gk = Dense(dk, name="gk_up")(tokens(kernel("gk_down", self.gate_rank)))
        gk = split(jax.nn.log_sigmoid(gk) / self.gate_normalizer, hk)
        o = gla_last(q, k, v, gk)
        scale = self.param("g_norm_scale", nn.initializers.ones, (hv,))
        o = o * jax.lax.rsqrt(jnp.mean(o**2, axis=-1, keepdims=True) + self.norm_eps) * scale
        g = split(Dense(dv, use_bias=False, name="g_proj")(last), hv)
        o = (o * nn.swish(g)).reshape(*o.shape[:-2], dv)
        return Dense(self.hidden, use_bias=False, name="o_proj")(o)
