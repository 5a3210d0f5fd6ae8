"""PPO: learns a tiny control task; GAE; determinism; an interrupted and resumed run equals an uninterrupted one."""

from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.policies.networks import NetworkConfig
from dragmesh2_jax.ppo.checkpoint import load_checkpoint, save_checkpoint
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.ppo.losses import compute_gae
from dragmesh2_jax.ppo.train import epoch_jit, init_jit, make_train
from dragmesh2_jax.runs.commands import load_run
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.runs.session import start_or_resume
from dragmesh2_jax.task.protocol import Obs, State
from tests.conftest import tiny_program, tiny_spec


class PointMass:
    """A 2-D point mass pushed towards the origin: the tiny control task PPO must solve.

    Action a[:2] in [-1, 1] sets the velocity (0.1 per step); reward -|x|; 30-step episodes (truncated).
    An env of the protocol (task/protocol.py), so the unchanged training program drives it."""

    action_size = 2
    active = jnp.ones(2, bool)
    config = SimpleNamespace(episode_length=30)
    data = jnp.zeros(())  # nothing object-specific

    def bind(self, data):
        return self

    def signature(self):
        return ("point_mass",)

    def _obs(self, x):
        return Obs(state=x, history=jnp.zeros((2, 4)), aux=jnp.zeros(1), privileged=jnp.zeros(1), step=jnp.int32(0))

    def reset(self, key, damping_scale=None, start=None):  # one start: the position is drawn
        key, k = jax.random.split(key)
        x = jax.random.uniform(k, (2,), minval=-1, maxval=1)
        zero = jnp.float32(0)
        m = {k: zero for k in ("success", "progress", "detach", "episode_return", "action_abs_max",
                               "active_abs_max", "action_l2", "nonfinite", "overflow")}
        return State(physics=x, obs=self._obs(x), reward=zero, done=jnp.bool_(False), terminated=jnp.bool_(False),
                     truncated=jnp.bool_(False), final_obs=self._obs(x), metrics=m,
                     info={"rng": key, "t": jnp.int32(0), "ret": zero})

    def step(self, s, action):
        a = jnp.clip(action, -1, 1)
        x = s.physics + 0.1 * a[:2]
        r = -jnp.linalg.norm(x)
        t = s.info["t"] + 1
        trunc = t >= self.config.episode_length
        ret = s.info["ret"] + r
        m = {"success": (jnp.linalg.norm(x) < 0.1).astype(jnp.float32), "progress": jnp.float32(0),
             "detach": jnp.float32(0), "episode_return": ret, "action_abs_max": jnp.abs(a).max(),
             "active_abs_max": jnp.abs(a).max(), "action_l2": jnp.linalg.norm(a), "nonfinite": jnp.float32(0),
             "overflow": jnp.float32(0)}
        return State(physics=x, obs=self._obs(x), reward=r, done=trunc, terminated=jnp.bool_(False), truncated=trunc,
                     final_obs=self._obs(x), metrics=m, info={**s.info, "t": t, "ret": ret})

    def restart(self, s):
        return self.reset(s.info["rng"])

    def adaptive_weights(self):  # a reward without adaptive weights
        return {}

    def bind_weights(self, data, weights):
        return data

    def update_weights(self, weights, metrics, steps):
        return weights, metrics


def test_ppo_solves_a_point_mass():
    cfg = PPOConfig(num_envs=32, rollout_len=30, update_epochs=4, num_minibatches=4, lr=3e-3)
    net = NetworkConfig(encoder="none", state_sizes=(64, 64), log_std_init=-1.0)
    program = make_train(PointMass(), net, cfg, "state_only")
    ts = init_jit(program, program.task.data, jax.random.PRNGKey(0))
    first = None
    for _ in range(40):
        ts, m = epoch_jit(program, program.task.data, ts)
        first = float(m["reward"]) if first is None else first
    last = float(m["reward"])
    # random at first: few episodes end near the goal; solved: nearly all end within 0.1 of it, and the mean
    # per-step distance (which includes the approach from up to 1.4 away) drops by a third or more
    assert float(m["success"]) > 0.8
    assert last > 0.7 * first


class CostlyPointMass(PointMass):
    """The point mass with a constraint's per-step cost, the squared first action channel as the policy gave it
    (before the clip), and the cost its weights' rule was given (``counted``) among the epoch's metrics."""

    def reset(self, key, damping_scale=None, start=None):
        s = super().reset(key, damping_scale, start)
        return s.replace(metrics={**s.metrics, "cost_action": jnp.float32(0)})

    def step(self, s, action):
        n = super().step(s, action)
        return n.replace(metrics={**n.metrics, "cost_action": action[0] ** 2})

    def update_weights(self, weights, metrics, steps):
        return weights, {**metrics, "counted": jnp.mean(steps["cost_action"])}


def test_mean_worlds_act_on_the_mean_and_the_costs_are_counted_on_them():
    """With a quarter of 16 worlds on the mean, the cost the weights' rule reads is the mean action's (the freshly built
    policy's mean is near 0), where with none it is the sampled one's, about the policy's variance std^2 = e^-2."""
    net = NetworkConfig(encoder="none", state_sizes=(16,), log_std_init=-1.0)
    counted = {}
    for share in (0.0, 0.25):
        config = PPOConfig(num_envs=16, rollout_len=30, mean_share=share)
        program = make_train(CostlyPointMass(), net, config, "state_only")
        ts = init_jit(program, program.task.data, jax.random.PRNGKey(0))
        _, m = epoch_jit(program, program.task.data, ts)
        counted[config.mean_worlds] = float(m["counted"])
    assert counted[0] == pytest.approx(np.exp(-2.0), rel=0.25)
    assert counted[4] < 0.05 * counted[0]


def test_gae_truncation_and_termination():
    r = jnp.array([[1.0], [1.0], [1.0]])
    v = jnp.zeros((3, 1))
    adv, ret = compute_gae(r, v, jnp.array([[0.0], [1.0], [0.0]]), jnp.array([10.0]), gamma=0.5, lam=1.0)
    # the episode boundary after step 1 stops bootstrapping; the last step bootstraps from last_value
    np.testing.assert_allclose(np.asarray(ret)[:, 0], [1.5, 1.0, 6.0])


def test_same_seed_same_metrics_and_exact_resume(tmp_path):
    p = tiny_program()
    data, key = p.task.data, jax.random.PRNGKey(7)
    a, b = init_jit(p, data, key), init_jit(p, data, key)
    rows_a = []
    for _ in range(3):
        a, m = epoch_jit(p, data, a)
        rows_a.append({k: float(v) for k, v in m.items()})
    # interrupted after one epoch, saved, restored into a fresh template, continued
    b, mb = epoch_jit(p, data, b)
    assert {k: float(v) for k, v in mb.items()} == rows_a[0]
    save_checkpoint(b, tmp_path / "ck")
    b = load_checkpoint(init_jit(p, data, jax.random.PRNGKey(123)), tmp_path / "ck")
    for i in (1, 2):
        b, mb = epoch_jit(p, data, b)
        assert {k: float(v) for k, v in mb.items()} == rows_a[i]
    for x, y in zip(jax.tree.leaves(a.params), jax.tree.leaves(b.params), strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def test_aux_warmup_schedule():
    c = PPOConfig()
    assert float(c.aux_weight_at(0)) == 0.0 and float(c.aux_weight_at(10)) == 0.0
    assert float(c.aux_weight_at(25)) == pytest.approx(0.005) and float(c.aux_weight_at(100)) == pytest.approx(0.01)


def test_bad_ppo_config():
    with pytest.raises(DragMeshError):
        PPOConfig(num_envs=0)
    with pytest.raises(DragMeshError):
        PPOConfig(num_envs=3, rollout_len=3, num_minibatches=2)
    assert PPOConfig(num_envs=4, mean_share=0.1).mean_worlds == 1  # rounded up
    with pytest.raises(DragMeshError, match="mean_share"):  # at least one world must explore
        PPOConfig(num_envs=1, mean_share=0.1)


def test_policy_trained_on_one_backend_loads_on_the_other(tmp_path):
    run = RunDir(tmp_path / "run")
    _, ts, _ = start_or_resume(tiny_spec(schedule={"robust_every": 0}), [run], resume=False, progress=False)
    program, loaded, _, _ = load_run(run.checkpoint("final"), backend="mjx")
    assert program.task.backend.name == "mjx"
    for x, y in zip(jax.tree.leaves(ts.params), jax.tree.leaves(loaded.params), strict=True):
        np.testing.assert_array_equal(np.asarray(x)[0], np.asarray(y))
    np.testing.assert_array_equal(np.asarray(ts.state_stats.mean)[0], np.asarray(loaded.state_stats.mean))
