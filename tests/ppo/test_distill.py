"""Distillation (``ppo/distill.py``, ``PPOConfig.distill_coef``): each world's step is labelled by its object's
teacher; the student's mean moves to its teachers' actions; the worlds of an object without a teacher carry no label."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.policies.networks import NetworkConfig
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.ppo.distill import Teachers
from dragmesh2_jax.ppo.train import epoch_jit, init_jit, init_runs, make_train, policy_params, seed_keys, train
from dragmesh2_jax.task.protocol import Obs
from tests.ppo.test_ppo import PointMass

NET = NetworkConfig(encoder="none", state_sizes=(32, 32), log_std_init=-1.0)


class TwoPointMasses(PointMass):
    """The point mass as a mix of two objects: each world's ``info["object"]`` is drawn at its reset."""

    num_objects = 2

    def signature(self):  # another program than the point mass's (jit caches programs by their signature)
        return ("two_point_masses",)

    def reset(self, key, damping_scale=None, start=None):
        s = super().reset(key, damping_scale, start)
        obj = jax.random.randint(jax.random.fold_in(key, 1), (), 0, 2)
        return s.replace(info={**s.info, "object": obj})

    def step(self, s, action):
        n = super().step(s, action)
        return n.replace(info={**n.info, "object": s.info["object"]})

    def check_overflow(self, count, where):  # no engine buffers to overflow
        pass


def _program(task=None, **ppo):
    return make_train(task or PointMass(), NET, PPOConfig(num_envs=16, rollout_len=30, lr=3e-3, **ppo), "state_only")


def _teacher(program, key: int) -> dict:
    """A policy of ``program``'s network whose mean is far from a fresh one's: its output layer scaled up."""
    ts = init_jit(program, program.task.data, jax.random.PRNGKey(key))
    params = jax.tree_util.tree_map_with_path(
        lambda path, x: 30 * x if "mu" in jax.tree_util.keystr(path) else x, ts.params)
    stats = ts.state_stats.update(jax.random.normal(jax.random.PRNGKey(key + 100), (64, 2)) * 3.0 + 1.0)
    return policy_params(ts.replace(params=params, state_stats=stats))


def _probe(n: int = 64) -> Obs:
    x = jax.random.uniform(jax.random.PRNGKey(5), (n, 2), minval=-1, maxval=1)
    return Obs(state=x, history=jnp.zeros((n, 2, 4)), aux=jnp.zeros((n, 1)), privileged=jnp.zeros((n, 1)),
               step=jnp.zeros(n, jnp.int32))


def test_each_world_is_labelled_by_its_objects_teacher():
    program = _program()
    policy = program.make_policy(True)
    a, b = _teacher(program, 1), _teacher(program, 2)
    obs = _probe(4)
    labels, taught = Teachers.stack([a, None]).label(policy, obs, jnp.array([0, 1, 1, 0]))
    np.testing.assert_array_equal(np.asarray(taught), [1, 0, 0, 1])
    both, _ = Teachers.stack([a, b]).label(policy, obs, jnp.array([0, 1, 1, 0]))
    for i, who in enumerate((a, b, b, a)):
        one = jax.tree.map(lambda x: x[i:i + 1], obs)  # noqa: B023
        np.testing.assert_allclose(np.asarray(both[i]), np.asarray(policy(who, one, None)[0]), atol=1e-5)
    np.testing.assert_allclose(np.asarray(labels)[[0, 3]], np.asarray(both)[[0, 3]], atol=1e-6)
    # each with its own normalisers: the student's (fresh) statistics would give other actions
    fresh = {**a, "state_stats": init_jit(program, program.task.data, jax.random.PRNGKey(0)).state_stats}
    assert not np.allclose(np.asarray(policy(fresh, obs, None)[0]), np.asarray(both[0]), atol=1e-3)
    with pytest.raises(DragMeshError, match="at least one"):
        Teachers.stack([None, None])


def _gap(program, ts, teacher) -> float:
    """The squared distance of the student's deterministic action to the teacher's over a probe of states."""
    policy, obs = program.make_policy(True), _probe()
    return float(jnp.mean((policy(policy_params(ts), obs, None) - policy(teacher, obs, None)) ** 2))


def test_the_student_moves_to_its_teachers_actions():
    """With the label loss the student's mean closes 90% of its gap to the teacher's in 20 epochs, five times more of
    it than PPO alone from the same seed."""
    teacher = _teacher(_program(), 1)
    gaps = {}
    for coef in (0.0, 5.0):
        program = _program(distill_coef=coef)
        ts = init_jit(program, program.task.data, jax.random.PRNGKey(0))
        start = _gap(program, ts, teacher)
        teachers = Teachers.stack([teacher]) if coef else None
        for _ in range(20):
            ts, m = epoch_jit(program, program.task.data, ts, teachers=teachers)
        gaps[coef] = _gap(program, ts, teacher) / start
    assert float(m["taught"]) == 1.0 and "distill_loss" in m
    assert gaps[5.0] < 0.1 and gaps[5.0] < 0.2 * gaps[0.0]


def test_only_the_worlds_of_a_taught_object_carry_a_label():
    """In a two-object mix whose one teacher teaches the first object, about half the steps are taught; with neither
    object taught, none is, and the label loss is 0 (tests/ppo/test_losses.py: an untaught step gets no gradient)."""
    task = TwoPointMasses()
    program = _program(task, distill_coef=5.0)
    teachers = Teachers.stack([_teacher(_program(task), 1), None])
    ts = init_jit(program, task.data, jax.random.PRNGKey(0))
    _, m = epoch_jit(program, task.data, ts, teachers=teachers)
    assert 0.25 < float(m["taught"]) < 0.75 and float(m["distill_loss"]) > 0
    _, m = epoch_jit(program, task.data, ts, teachers=teachers.replace(taught=jnp.zeros(2)))
    assert float(m["taught"]) == 0.0 and float(m["distill_loss"]) == 0.0


def test_teachers_label_only_a_distilled_run_one_per_object():
    task = TwoPointMasses()
    plain, taught = _program(task), _program(task, distill_coef=1.0)
    teachers = Teachers.stack([_teacher(plain, 1), None])
    with pytest.raises(DragMeshError, match="label only a run that distils"):  # labels nothing would read
        epoch_jit(plain, task.data, init_jit(plain, task.data, jax.random.PRNGKey(0)), teachers=teachers)
    with pytest.raises(DragMeshError, match="1 objects' teachers for a run over 2"):
        epoch_jit(taught, task.data, init_jit(taught, task.data, jax.random.PRNGKey(0)),
                  teachers=Teachers.stack([_teacher(plain, 1)]))


def test_the_teachers_label_until_the_label_loss_has_fallen_to_zero():
    """With the loss falling to 0 over two epochs, the third epoch makes no labels (its columns logged at 0)."""
    program = _program(TwoPointMasses(), distill_coef=2.0, distill_epochs=2)
    rows = []
    ts = init_runs(program, program.task.data, seed_keys([0]))
    teacher = _teacher(program, 1)
    train(program, program.task.data, ts, 3, on_epoch=lambda ts, m: rows.append(m),
          teachers=Teachers.stack([teacher, teacher]))
    assert [(float(m["w_distill"][0]), float(m["taught"][0])) for m in rows] == [(2.0, 1.0), (1.0, 1.0), (0.0, 0.0)]
    assert float(rows[0]["distill_loss"][0]) > 0 and float(rows[2]["distill_loss"][0]) == 0.0


def test_the_label_loss_schedule():
    c = PPOConfig(distill_coef=2.0, distill_epochs=10)
    assert [float(c.distill_coef_at(e)) for e in (0, 5, 10, 50)] == [2.0, 1.0, 0.0, 0.0]
    assert float(PPOConfig(distill_coef=2.0).distill_coef_at(1000)) == 2.0
    with pytest.raises(DragMeshError, match="distill_coef > 0 too"):
        PPOConfig(distill_epochs=10)
    with pytest.raises(DragMeshError, match="distill_coef must be finite"):
        PPOConfig(distill_coef=-1.0)
