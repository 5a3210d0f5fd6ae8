"""Contact-load sensing beyond the paper: the force-aware observation and the privileged critic's inputs, and the
presets that use them train (the load constraint's multiplier moving by dual ascent). The sensors agree between
engines within a stated tolerance: MJX-JAX in tests/task/test_tracking.py (the expert drag on 45261), MJX-Warp in
tests/physics/test_mjx_backend.py."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.policies.methods import get_method, task_overrides
from dragmesh2_jax.ppo.train import epoch_jit, init_jit, load_lambda_update
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.scene import FORCE_SIZE
from dragmesh2_jax.task.config import LoadConstraint, RewardConfig
from dragmesh2_jax.task.env import PRIVILEGED_SIZE, STATE_SIZE, TOKEN_SIZE, make_batched
from dragmesh2_jax.task.rewards import load_cost, reward_terms
from tests.conftest import tiny_program

OBJ = str(default_object())


def forces(task, steps=10, n=2):
    reset, step = make_batched(task)

    def run(keys):
        s = reset(keys, jnp.ones(n))

        def body(s, _):
            s = step(s, jnp.zeros((n, 51)))
            return s, (jax.vmap(task.kinematics)(s.physics).force, s.obs)

        return jax.lax.scan(body, s, None, length=steps)[1]

    return jax.device_get(jax.jit(run)(jax.random.split(jax.random.PRNGKey(0), n)))


def test_force_observation_layout_and_privileged_block():
    task = load_task(OBJ, None, backend="mujoco", force_obs=True)
    force, obs = forces(task)
    assert obs.state.shape[-1] == STATE_SIZE + FORCE_SIZE and obs.history.shape[-1] == TOKEN_SIZE + FORCE_SIZE
    assert obs.privileged.shape[-1] == PRIVILEGED_SIZE
    load = np.sign(force) * np.log1p(np.abs(force))
    np.testing.assert_allclose(obs.state[..., STATE_SIZE:], load, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(obs.history[..., -1, TOKEN_SIZE:], load, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(obs.privileged[..., 0], 1.0)  # the damping multiplier of each world
    assert force[..., 6:].min() >= 0 and force[..., 6:].sum(-1).max() > 1.0  # the grasp touches the handle


def test_the_load_constraint_weighs_each_steps_cost_by_the_multiplier_the_trainer_binds():
    """r_t carries -lambda c_t with c_t = max(0, |F_wrist| - f_limit) / f_limit, reported as the step's load_cost
    (with a limit the grasp always passes, the cost is positive from the first step)."""
    limit = LoadConstraint(f_limit=1.0)
    task = load_task(OBJ, None, backend="mujoco", reward=RewardConfig(load_constraint=limit))
    weighed = task.bind(task.data.replace(params=task.data.params.replace(load_lambda=jnp.float32(2.0))))

    def first_step(t):
        reset, step = make_batched(t)
        return step(reset(jax.random.split(jax.random.PRNGKey(0), 2), jnp.ones(2)), jnp.zeros((2, 51)))

    free, paid = jax.device_get(jax.jit(lambda: (first_step(task), first_step(weighed)))())
    cost = free.metrics["load_cost"]
    assert (cost > 0).all() and np.allclose(paid.metrics["load_cost"], cost)
    np.testing.assert_allclose(paid.reward, free.reward - 2.0 * cost, rtol=1e-5, atol=1e-5)
    assert "load_cost" not in first_step(load_task(OBJ, None, backend="mujoco")).metrics  # off in the paper


def test_the_blind_cmdp_preset_trains_and_its_multiplier_takes_one_dual_ascent_step_per_epoch():
    """hold_blind_cmdp (the policy never observes the load; the cost and the critic do): lambda = clip(0 + lr (J_c -
    budget), 0, lambda_max) after the first epoch, J_c the epoch's mean cost per step."""
    program = tiny_program("hold_blind_cmdp", OBJ)
    limit = program.task.config.reward.load_constraint
    assert limit == get_method("hold_cmdp").load_constraint and not program.task.config.force_obs
    ts, m = epoch_jit(program, program.task.data, init_jit(program, program.task.data, jax.random.PRNGKey(0)))
    assert int(ts.epoch) == 1 and np.isfinite(float(m["loss"])) and float(m["load_cost"]) >= 0
    assert float(ts.load_lambda) == pytest.approx(
        min(max(limit.lr * (float(m["load_cost"]) - limit.budget), 0.0), limit.lambda_max), abs=1e-6)
    assert float(m["load_lambda"]) == float(ts.load_lambda) and float(ts.aram_lambda) == 0.0


def test_dual_ascent_raises_the_multiplier_over_budget_lowers_it_under_and_keeps_it_in_bounds():
    c = LoadConstraint(budget=0.01, lr=50.0, lambda_max=20.0)
    assert float(load_lambda_update(c, 1.0, 0.03)) == pytest.approx(2.0)  # 1 + 50 (0.03 - 0.01)
    assert float(load_lambda_update(c, 1.0, 0.0)) == pytest.approx(0.5)  # relaxes once the pull is under budget
    assert float(load_lambda_update(c, 0.1, 0.0)) == 0.0 and float(load_lambda_update(c, 19.0, 1.0)) == 20.0
    cost = lambda f: float(load_cost(c, jnp.asarray([0.0, f, 0.0])))  # noqa: E731
    assert cost(0.5 * c.f_limit) == 0.0 and cost(c.f_limit) == 0.0 and cost(1.5 * c.f_limit) == pytest.approx(0.5)
    with pytest.raises(DragMeshError, match="load constraint"):
        LoadConstraint(budget=-0.1)


def test_load_budget_reward_penalises_only_the_pull_beyond_what_the_grasp_holds():
    cfg = task_overrides(get_method("pica_grip"))["reward"]
    assert cfg.w_load > 0 and dataclasses.replace(cfg, w_load=0.0) == RewardConfig()  # only the load term differs
    args = (jnp.zeros(51), jnp.float32(0.05), jnp.float32(0.0), jnp.float32(0.0), jnp.float32(0.0))
    load = lambda f: float(reward_terms(cfg, *args, jnp.asarray([f, 0.0, 0.0]))["load"])  # noqa: E731
    assert load(0.5 * cfg.f_hold) == 0.0 and load(cfg.f_hold) == 0.0
    assert load(2 * cfg.f_hold) == pytest.approx(-cfg.w_load) and load(3 * cfg.f_hold) == pytest.approx(-2 * cfg.w_load)
    assert float(reward_terms(RewardConfig(), *args, jnp.asarray([1e3, 0.0, 0.0]))["load"]) == 0.0  # off in the paper
