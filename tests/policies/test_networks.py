"""Policy networks: GLA matches a NumPy reference; every encoder builds; aux gradients reach only the
temporal branch and the aux head; the aux targets are structurally not an input."""

import functools
import inspect
from types import SimpleNamespace

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.policies.gla import GatedLinearAttention, TokenWindows, gla_last, gla_recurrent
from dragmesh2_jax.policies.networks import (
    ENCODERS,
    MLP,
    ActorCritic,
    NetworkConfig,
    TemporalEncoder,
    make_inference_fn,
)
from dragmesh2_jax.ppo import train as train_lib
from dragmesh2_jax.runs.overrides import NO_PHYSICAL_SIGNALS
from dragmesh2_jax.runs.presets import METHODS, get_method
from dragmesh2_jax.task.protocol import Obs


def init_all(net: ActorCritic, key, *inputs):
    """Every parameter of ``net`` (actor, critic, aux head) as one compiled program, not op by op."""
    return jax.jit(functools.partial(net.init, method=ActorCritic.init_all))(key, *inputs)


def gla_numpy(q, k, v, g):
    """Straightforward loops: S_t = diag(exp g_t) S_{t-1} + k_t^T v_t, o_t = q_t S_t, per head."""
    T, H, dk = q.shape
    S = np.zeros((H, dk, v.shape[-1]))
    out = np.zeros((T, H, v.shape[-1]))
    for t in range(T):
        for h in range(H):
            S[h] = np.exp(g[t, h])[:, None] * S[h] + np.outer(k[t, h], v[t, h])
            out[t, h] = q[t, h] @ S[h]
    return out


def test_gla_recurrence_matches_numpy():
    rng = np.random.default_rng(0)
    T, H, dk, dv = 16, 4, 16, 32
    q, k = rng.normal(size=(T, H, dk)), rng.normal(size=(T, H, dk))
    v = rng.normal(size=(T, H, dv))
    g = -np.abs(rng.normal(size=(T, H, dk))) / 16
    o, S = gla_recurrent(*(jnp.asarray(x, jnp.float32) for x in (q, k, v, g)))
    np.testing.assert_allclose(np.asarray(o), gla_numpy(q, k, v, g), rtol=2e-4, atol=2e-4)
    assert S.shape == (H, dk, dv)


def test_gla_closed_form_last_token_equals_the_recurrence():
    """The layer computes only o_T, in closed form: it equals the recurrence's last output (batched)."""
    rng = np.random.default_rng(1)
    B, T, H, dk, dv = 3, 16, 4, 16, 32
    q, k = rng.normal(size=(B, T, H, dk)), rng.normal(size=(B, T, H, dk))
    v = rng.normal(size=(B, T, H, dv))
    g = np.log(1 / (1 + np.exp(-rng.normal(size=(B, T, H, dk))))) / 16  # log-sigmoid / 16, as the layer
    f = lambda x: jnp.asarray(x, jnp.float32)  # noqa: E731
    o_rec, _ = gla_recurrent(f(q), f(k), f(v), f(g))
    o_last = gla_last(f(q[:, -1]), f(k), f(v), f(g))
    np.testing.assert_allclose(np.asarray(o_last), np.asarray(o_rec[:, -1]), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(np.asarray(o_last[0]), gla_numpy(q[0], k[0], v[0], g[0])[-1], rtol=2e-4, atol=2e-4)


def test_gla_layer_dimensions_follow_the_reference():
    layer = GatedLinearAttention()
    x = jnp.ones((2, 16, 128))
    params = layer.init(jax.random.PRNGKey(0), x)["params"]
    assert params["q_proj"]["kernel"].shape == (128, 64) and params["v_proj"]["kernel"].shape == (128, 128)
    assert params["gk_down"]["kernel"].shape == (128, 16) and params["gk_up"]["kernel"].shape == (16, 64)
    assert params["g_norm_scale"].shape == (32,)
    assert layer.apply({"params": params}, x).shape == (2, 128)  # the last token only


def test_gla_with_the_token_projection_folded_in_equals_projecting_first():
    layer = GatedLinearAttention()
    tokens = jax.random.normal(jax.random.PRNGKey(1), (3, 16, 102))
    W, b = jax.random.normal(jax.random.PRNGKey(2), (102, 128)) * 0.1, jnp.linspace(-0.1, 0.1, 128)
    params = layer.init(jax.random.PRNGKey(0), tokens @ W + b)
    folded = layer.apply(params, tokens, (W, b))
    np.testing.assert_allclose(np.asarray(folded), np.asarray(layer.apply(params, tokens @ W + b)), rtol=1e-4,
                               atol=1e-4)


def _rollout_histories(stream, done, L):
    """The windows AutoReset hands the policy: each step shifts in the world's newest token; after a step whose
    episode ended, the window is zeros but the new episode's first token."""
    T, N = done.shape
    out = np.zeros((T, N, L, stream.shape[-1]), np.float32)
    for n in range(N):
        h = stream[n, :L].copy()
        for t in range(T):
            if t > 0:
                tok = stream[n, L - 1 + t]
                h = np.concatenate([np.zeros_like(h[:-1]), tok[None]]) if done[t - 1, n] else \
                    np.concatenate([h[1:], tok[None]])
            out[t, n] = h
    return out


def test_a_rollouts_windows_share_their_tokens_and_give_the_same_outputs():
    """TokenWindows (the update's history) hold each world's token stream once: every window, episode starts inside
    the rollout included, is exactly the one AutoReset gave the policy, and the GLA encoder's outputs on them equal
    those on the windows themselves."""
    T, N, L, D = 7, 3, 4, 5
    rng = np.random.default_rng(0)
    stream = rng.normal(size=(N, L + T - 1, D)).astype(np.float32)
    done = np.zeros((T, N), bool)
    done[1, 0] = done[4, 0] = done[2, 2] = True  # world 0 restarts twice, world 2 once, world 1 never
    hist = _rollout_histories(stream, done, L)
    norm = lambda x: (x - 0.3) / 1.7  # noqa: E731  a token normaliser: the zero token is not zero after it
    w = TokenWindows.of_rollout(jnp.asarray(hist), jnp.asarray(done), norm)
    explicit = np.asarray(norm(jnp.asarray(hist.reshape(T * N, L, D))))
    np.testing.assert_array_equal(np.asarray(w.materialize()), explicit)
    assert w.stream.shape == (N, L + T - 1, D)  # 27 distinct tokens for 84 window slots
    idx = jnp.asarray([5, 0, 17])
    np.testing.assert_array_equal(np.asarray(w.take(idx).materialize()), explicit[np.asarray(idx)])
    enc = TemporalEncoder("gla", dim=16, heads=2)
    params = enc.init(jax.random.PRNGKey(0), jnp.asarray(explicit))
    np.testing.assert_allclose(np.asarray(enc.apply(params, w)), np.asarray(enc.apply(params, jnp.asarray(explicit))),
                               rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize("encoder", ENCODERS)
def test_every_encoder_builds_and_runs(encoder):
    net = ActorCritic(NetworkConfig(encoder=encoder))
    s, h, p = jnp.ones((3, 120)), jnp.ones((3, 16, 102)), jnp.ones((3, 24))
    params = init_all(net, jax.random.PRNGKey(0), s, h, p)
    mu, log_std, v, z = jax.jit(net.apply)(params, s, h, p)
    assert mu.shape == (3, 51) and v.shape == (3,)
    np.testing.assert_allclose(log_std, -2.0)  # state-independent log-std, init -2.0
    assert (z is None) == (encoder == "none")


@pytest.mark.parametrize("encoder", ENCODERS)
def test_linear_maps_start_as_the_references_pytorch_linears(encoder):
    """Every kernel is drawn as PyTorch's nn.Linear draws it, U(-1/sqrt(fan_in), 1/sqrt(fan_in)), every bias is
    zero (the reference's networks, design §6); so the initial action means of unit-variance inputs sit inside the
    action bounds. flax's default (lecun_normal, 3x the variance) puts 7-17% of them beyond +-1."""
    net = ActorCritic(NetworkConfig(encoder=encoder))
    ks, kh = jax.random.split(jax.random.key(1))
    s, h, p = jax.random.normal(ks, (4096, 120)), jax.random.normal(kh, (4096, 16, 102)), jnp.zeros((4096, 24))
    params = init_all(net, jax.random.key(0), s[:1], h[:1], p[:1])
    kernels = 0
    for path, w in jax.tree_util.tree_leaves_with_path(params):
        name = [getattr(k, "key", "") for k in path]
        if name[-1] == "bias":
            assert not np.any(w), name
        elif name[-1] == "kernel":
            # a DenseGeneral kernel of attention: (in, heads, head_dim), or (heads, head_dim, out) for "out"
            fan_in = int(np.prod(w.shape[:-1])) if name[-2] == "out" else w.shape[0]
            assert np.abs(w).max() <= fan_in**-0.5, name
            if w.size >= 4096:
                assert np.std(w) == pytest.approx((3 * fan_in) ** -0.5, rel=0.1), name
            kernels += 1
    assert kernels >= 5  # the state MLP, mu, value, aux head at least
    mu = np.asarray(jax.jit(net.apply)(params, s, h, p)[0])
    assert np.mean(np.abs(mu) > 1.0) < 0.01


def test_privileged_critic_sees_what_the_actor_never_does():
    """Asymmetric critic: the value depends on the privileged block, the action mean does not; the shared
    critic (the paper's) ignores it."""
    s, h = jnp.ones((2, 120)), jnp.ones((2, 16, 102))
    p0, p1 = jnp.zeros((2, 24)), jnp.full((2, 24), 3.0)
    for critic, value_moves in (("privileged", True), ("shared", False)):
        net = ActorCritic(NetworkConfig(critic=critic))
        params = init_all(net, jax.random.PRNGKey(0), s, h, p0)
        apply = jax.jit(net.apply)
        mu0, _, v0, _ = apply(params, s, h, p0)
        mu1, _, v1, _ = apply(params, s, h, p1)
        np.testing.assert_array_equal(mu0, mu1)
        assert bool(jnp.any(v0 != v1)) == value_moves
        mu_actor, _ = net.apply(params, s, h, method=ActorCritic.actor)  # eager: XLA fuses the jitted one otherwise
        np.testing.assert_allclose(mu_actor, mu0, rtol=1e-5, atol=1e-6)  # float32 rounding, not another actor


def test_methods_are_override_sets():
    assert {"pica", "state_only", "flat_history", "gru", "transformer", "gla_only", "pica_flat"} <= set(METHODS)
    sizes = ("state_sizes", "hist_dim", "heads", "log_std_init", "critic_sizes")
    assert not [path for m in METHODS.values() for path in m.overrides if path.split(".")[-1] in sizes]  # Table 8's
    load = get_method("pica_load").overrides
    assert load["network.critic"] == "privileged" and "network.encoder" not in load  # GLA, the paper's
    assert load["task.force_obs"] and load["task.damping_range"] == (1.0, 4.0) and load["task.reset_noise"] is not None
    assert get_method("pica").overrides == {}  # the paper's PICA: the defaults
    # without the physical signals: no r_bound / r_contact, nominal damping, no auxiliary loss
    assert NO_PHYSICAL_SIGNALS.items() <= get_method("gla_only").overrides.items()
    assert "network.encoder" not in get_method("gla_only").overrides
    assert get_method("pica_flat").overrides == {"network.encoder": "flat"}


def test_the_network_config_refuses_an_unknown_encoder_or_critic():
    for bad in ({"encoder": "lstm"}, {"critic": "oracle"}):
        with pytest.raises(DragMeshError, match="unknown"):
            NetworkConfig(**bad)


def test_aux_loss_gradients_reach_only_the_temporal_branch_and_aux_head():
    net = ActorCritic(NetworkConfig(encoder="gla"))
    s, h = jax.random.normal(jax.random.PRNGKey(1), (4, 120)), jax.random.normal(jax.random.PRNGKey(2), (4, 16, 102))
    priv = jnp.zeros((4, 24))
    params = init_all(net, jax.random.PRNGKey(0), s, h, priv)

    def aux_loss(p):
        _, _, _, z = net.apply(p, s, h, priv)
        return jnp.sum(net.apply(p, z, method=ActorCritic.aux) ** 2)

    g = jax.jit(jax.grad(aux_loss))(params)["params"]
    norm = lambda t: float(sum(np.abs(np.asarray(x)).sum() for x in jax.tree.leaves(t)))  # noqa: E731
    assert norm(g["temporal"]) > 0 and norm(g["aux_head"]) > 0 and norm(g["aux_out"]) > 0
    assert norm(g["temporal"]["GatedLinearAttention_0"]) > 0
    for head in ("mu", "value", "state_mlp", "log_std"):
        assert norm(g[head]) == 0.0, head


def test_aux_targets_are_not_a_network_input():
    """The network's only inputs are obs.state, obs.history and obs.privileged; the aux block cannot reach it
    (neither the training program's inputs nor the exported policy)."""
    assert list(inspect.signature(ActorCritic.__call__).parameters) == ["self", "state", "history", "privileged"]
    assert "obs.aux" not in inspect.getsource(train_lib._inputs)
    obs = Obs(state=jnp.ones((2, 120)), history=jnp.ones((2, 16, 102)), aux=jnp.zeros((2, 4)),
              privileged=jnp.zeros((2, 24)), step=jnp.zeros(2, jnp.int32))
    net = ActorCritic(NetworkConfig(encoder="gla"))
    params = init_all(net, jax.random.PRNGKey(0), obs.state, obs.history, obs.privileged)
    program = SimpleNamespace(config=SimpleNamespace(normalize_obs=False))
    out1 = net.apply(params, *train_lib._inputs(program, None, obs))
    out2 = net.apply(params, *train_lib._inputs(program, None, obs.replace(aux=jnp.full((2, 4), 1e6))))
    np.testing.assert_array_equal(out1[0], out2[0])
    np.testing.assert_array_equal(out1[2], out2[2])
    policy = make_inference_fn(net, normalize_obs=False)(True)
    np.testing.assert_array_equal(policy({"net": params}, obs, None),
                                  policy({"net": params}, obs.replace(aux=jnp.full((2, 4), 1e6)), None))


def test_transformer_computes_only_the_last_token_of_a_causal_block():
    """One pre-LN causal block whose last token's output is z_hist: computing that token alone (its query
    against every key) equals the full block's last row, and every token of the window reaches it."""
    class FullBlock(nn.Module):
        @nn.compact
        def __call__(self, history):
            x = nn.Dense(128, name="token_proj")(history)
            x = x + self.param("pos", nn.initializers.normal(0.02), (x.shape[-2], 128))
            h = nn.LayerNorm()(x)
            x = x + nn.MultiHeadDotProductAttention(num_heads=4)(h, h, mask=nn.make_causal_mask(x[..., 0]))
            x = x + nn.Dense(128)(MLP((256,))(nn.LayerNorm()(x)))
            return nn.LayerNorm(name="hist_norm")(x[..., -1, :])

    H = jax.random.normal(jax.random.key(1), (3, 16, 102))
    enc = TemporalEncoder(kind="transformer")
    params = enc.init(jax.random.key(0), H)
    np.testing.assert_allclose(enc.apply(params, H), FullBlock().apply(params, H), atol=1e-5)
    assert not np.allclose(enc.apply(params, H.at[:, 0].add(1.0)), enc.apply(params, H))
