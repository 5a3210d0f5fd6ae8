"""Contact-load sensing beyond the paper: the force-aware observation and the privileged critic's inputs, and the
presets that use them train (the constraints' multipliers moving by dual ascent). The sensors agree between
engines within a stated tolerance: MJX-JAX in tests/task/test_tracking.py (the expert drag on 45261), MJX-Warp in
tests/physics/test_mjx_backend.py."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.baselines.tracking import drag_targets
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.ppo.train import epoch_jit, init_jit
from dragmesh2_jax.runs.build import load_task, program_of
from dragmesh2_jax.runs.finetunes import PLAUSIBLE
from dragmesh2_jax.runs.presets import RECOMMENDED
from dragmesh2_jax.runs.spec import finetune_spec, method_defaults
from dragmesh2_jax.scene import FORCE_SIZE
from dragmesh2_jax.task.config import Constraint, RewardConfig
from dragmesh2_jax.task.env import PRIVILEGED_SIZE, TOKEN_SIZE, Events, make_batched
from dragmesh2_jax.task.observation import STATE_SIZE
from dragmesh2_jax.task.protocol import START_STEPS
from dragmesh2_jax.task.rewards import constraint_cost, multiplier_update, reward_terms
from tests.conftest import tiny_spec

OBJ = str(default_object())


def forces(task, steps=10, n=2):
    reset, step = make_batched(task)

    def run(keys):
        s = reset(keys, jnp.ones(n))

        def body(s, _):
            s = step(s, jnp.zeros((n, 51)))
            return s, (jax.vmap(task.kinematics)(s).force, s.obs)

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


def test_each_constraint_weighs_its_steps_cost_by_the_multiplier_the_trainer_binds():
    """r_t carries -sum_i lambda_i c_i: the load's c_t = max(0, |F_wrist| - limit) / limit, the palm's pace and
    saturation as rates (1 past the limit), each reported as the step's cost_<measure> (with limits the first step
    always passes, every cost is positive from the first step)."""
    limits = (Constraint("load", 1.0), Constraint("palm_speed", 1e-6, "rate"), Constraint("saturation", 0.5, "rate"),
              Constraint("wrist_saturation", 0.5, "rate"))
    task = load_task(OBJ, None, backend="mujoco", reward=RewardConfig(constraints=limits))
    weighed = task.bind(task.data.replace(params=task.data.params.replace(
        multipliers=jnp.asarray([2.0, 3.0, 5.0, 7.0], jnp.float32))))

    def first_step(t):
        reset, step = make_batched(t)
        return step(reset(jax.random.split(jax.random.PRNGKey(0), 2), jnp.ones(2)), jnp.ones((2, 51)))

    free, paid = jax.device_get(jax.jit(lambda: (first_step(task), first_step(weighed)))())
    load, pace, sat, wrist = (free.metrics[f"cost_{m}"] for m in ("load", "palm_speed", "saturation",
                                                                   "wrist_saturation"))
    assert (load > 0).all() and (pace == 1.0).all() and (sat == 1.0).all() and (wrist == 1.0).all()
    assert all(np.allclose(paid.metrics[k], free.metrics[k]) for k in free.metrics if k.startswith("cost_"))
    np.testing.assert_allclose(paid.reward, free.reward - 2.0 * load - 3.0 - 5.0 - 7.0, rtol=1e-5, atol=1e-4)
    assert not any(k.startswith("cost_") for k in first_step(load_task(OBJ, None, backend="mujoco")).metrics)
    # normalised: the same penalty over 1 + sum(lambda), the task's scale kept
    task = load_task(OBJ, None, backend="mujoco", reward=RewardConfig(constraints=limits, lagrangian="normalized"))
    normal = jax.device_get(jax.jit(lambda: first_step(task.bind(weighed.data)))())
    np.testing.assert_allclose(normal.reward, paid.reward / 18.0, rtol=1e-5, atol=1e-5)
    with pytest.raises(DragMeshError, match="one constraint per measure"):
        RewardConfig(constraints=(Constraint("load"), Constraint("load", 50.0)))


def test_the_settled_palm_pace_leaves_the_starts_settling_steps_out():
    """``settled_palm_speed`` is ``palm_speed`` from the step after the first START_STEPS on (the evaluation's settled
    figure) and 0 before: a start's hand settling onto its grasp is not the pace the policy chose."""
    limits = (Constraint("palm_speed", 1e-6, "rate"), Constraint("settled_palm_speed", 1e-6, "rate"))
    task = load_task(OBJ, None, backend="mujoco", reward=RewardConfig(constraints=limits))

    def run():
        def body(s, _):
            s = task.step(s, jnp.ones(51))
            return s, (s.metrics["cost_palm_speed"], s.metrics["cost_settled_palm_speed"])

        return jax.lax.scan(body, task.reset(jax.random.PRNGKey(0), jnp.float32(1.0)), None, length=START_STEPS + 3)[1]

    pace, settled = jax.device_get(jax.jit(run)())
    assert (pace == 1.0).all()  # the hand moves at every step
    assert (settled[:START_STEPS] == 0.0).all() and (settled[START_STEPS:] == 1.0).all()


def test_the_plausible_finetune_trains_the_recipe_and_each_multiplier_takes_one_dual_ascent_step_per_epoch():
    """The recipe under the plausible fine-tune (the policy never observes the load; the costs and the critic do):
    lambda_i = clip(0 + lr_i (J_i - budget_i), 0, lambda_max_i) after the first epoch, J_i the epoch's mean cost per
    step."""
    program = program_of(finetune_spec(tiny_spec(RECOMMENDED, OBJ), "plausible", "ck", 1))
    constraints = program.task.config.reward.constraints
    assert constraints == PLAUSIBLE and program.task.config.reward.lagrangian == "normalized"
    assert not program.task.config.force_obs
    ts, m = epoch_jit(program, program.task.data, init_jit(program, program.task.data, jax.random.PRNGKey(0)))
    assert int(ts.epoch) == 1 and np.isfinite(float(m["loss"])) and float(ts.aram_lambda) == 0.0
    assert 0 <= float(m["cost_wrist_saturation"]) <= float(m["clip099"])  # the wrist's DoFs among all
    for i, x in enumerate(constraints):
        cost = float(m[f"cost_{x.measure}"])
        assert 0 <= cost <= 1 and float(m[f"lambda_{x.measure}"]) == float(ts.multipliers[i])
        assert float(ts.multipliers[i]) == pytest.approx(min(max(x.lr * (cost - x.budget), 0.0), x.lambda_max),
                                                         abs=1e-5)


def test_lag_and_lead_are_how_far_the_part_trails_or_leads_the_expert_drag_at_its_own_pace():
    """lag_t = (schedule[t] - q_t) / (q_goal - q_start), the schedule the plan's target joint after step t of the
    expert drag, and lead_t = -lag_t: replayed, the expert keeps the part within a tenth of the motion range of it at
    x1 (no cost past a limit of 0.1 either way); a hand that holds still trails it by the plan's own progress (the
    excess cost past the limit) and leads it never; the drag replayed at twice its pace leads it."""
    limit = 0.1
    task = load_task(OBJ, None, backend="mujoco",
                     reward=RewardConfig(constraints=(Constraint("lag", limit), Constraint("lead", limit))))
    targets, steps, p = jnp.asarray(drag_targets(task)), 90, task.params

    def run(act):
        s = task.reset(jax.random.PRNGKey(0), jnp.float32(1.0))

        def body(s, t):
            s = act(s, t)
            return s, (s.metrics["q"], s.metrics["cost_lag"], s.metrics["cost_lead"])

        return jax.lax.scan(body, s, jnp.arange(steps))[1]

    expert, still, fast = jax.device_get(jax.jit(lambda: (
        run(lambda s, t: task.step_target(s, targets[t])), run(lambda s, t: task.step(s, jnp.zeros(51))),
        run(lambda s, t: task.step_target(s, targets[jnp.minimum(2 * t, len(targets) - 1)]))))())
    (q_expert, lag_expert, lead_expert), (q_still, cost_still, lead_still) = expert, still
    assert q_expert[-1] > q_expert[0] + 0.2 * (p.q_goal - p.q_start)
    assert lag_expert.max() == 0.0 and lead_expert.max() == 0.0 and lead_still.max() == 0.0
    lag = (np.asarray(p.schedule[:steps]) - q_still) / float(p.q_goal - p.q_start)
    np.testing.assert_allclose(cost_still, np.maximum(lag - limit, 0.0) / limit, rtol=1e-4, atol=1e-4)
    assert lag[-1] > 2 * limit and cost_still[-1] > 0
    lead = (fast[0] - np.asarray(p.schedule[:steps])) / float(p.q_goal - p.q_start)
    np.testing.assert_allclose(fast[2], np.maximum(lead - limit, 0.0) / limit, rtol=1e-4, atol=1e-4)
    assert fast[2].max() > 0


def test_action_change_is_how_far_the_applied_action_moved_since_the_last_step():
    """action_change_t = mean_i |a_t,i - a_(t-1),i| over the 51 channels, 0 at an episode's first step: a hand held
    at one action costs nothing; one that swings every channel between -0.5 and +0.5 moves 1.0 a step, an excess of
    (1.0 - limit) / limit; the expert drag, replayed, moves a hundredth of that."""
    limit = 0.1
    task = load_task(OBJ, None, backend="mujoco",
                     reward=RewardConfig(constraints=(Constraint("action_change", limit),)))
    targets, steps = jnp.asarray(drag_targets(task)), 20

    def run(act):
        s = task.reset(jax.random.PRNGKey(0), jnp.float32(1.0))

        def body(s, t):
            s = act(s, t)
            return s, s.metrics["cost_action_change"]

        return jax.lax.scan(body, s, jnp.arange(steps))[1]

    held, swung, expert = jax.device_get(jax.jit(lambda: (
        run(lambda s, t: task.step(s, jnp.full(51, 0.3))),
        run(lambda s, t: task.step(s, jnp.full(51, jnp.where(t % 2 == 0, 0.5, -0.5)))),
        run(lambda s, t: task.step_target(s, targets[t]))))())
    np.testing.assert_allclose(held, 0.0, atol=1e-6)
    assert swung[0] == 0.0
    np.testing.assert_allclose(swung[1:], (1.0 - limit) / limit, rtol=1e-5)
    assert expert.max() == 0.0


def _ending_reward(env, t: int, costs, success: bool = False, detach: bool = False):
    """``env._reward``'s (reward, terms) of a step t of a fresh episode that ends in ``success`` or ``detach`` (or
    not at all), with these constraint ``costs``."""
    s = env.reset(jax.random.PRNGKey(0), jnp.float32(1.0))
    k = env.kinematics(s)
    ev = Events(d=jnp.float32(0.2), q=k.obj_q, success=jnp.bool_(success), detach=jnp.bool_(detach),
                terminated=jnp.bool_(success or detach), truncated=jnp.bool_(False), step=jnp.int32(t))
    return env._reward(s, jnp.zeros(51), jnp.zeros(51), k, ev, jnp.bool_(True), jnp.asarray(costs, jnp.float32))[:2]


def test_a_normalized_lagrangian_charges_a_detached_episode_every_step_it_had_left():
    """With multipliers (2, 3) and no cost this step, a world that detaches at step t pays 5 (T - t) more than the
    plain reward, all over 1 + 5; a step that does not end in detachment pays nothing more."""
    limits = (Constraint("load", 1e6), Constraint("palm_speed", 1e6, "rate"))
    task = load_task(OBJ, None, backend="mujoco", reward=RewardConfig(constraints=limits, lagrangian="normalized"))
    task = task.bind(task.data.replace(params=task.data.params.replace(multipliers=jnp.asarray([2.0, 3.0]))))
    plain = load_task(OBJ, None, backend="mujoco")
    T, t = task.config.episode_length, 10
    reward = lambda env, detach: _ending_reward(env, t, [0.0, 0.0], detach=detach)[0]  # noqa: E731
    for detach in (True, False):
        charged, free = jax.device_get(jax.jit(lambda d=detach: (reward(task, d), reward(plain, d)))())
        assert float(charged) == pytest.approx((float(free) - 5.0 * (T - t) * detach) / 6.0, rel=1e-5, abs=1e-5)


def test_a_horizon_cost_charges_a_successful_episode_past_its_limit_every_step_it_had_left():
    """Multipliers (2, 3) on a peak and a horizon constraint, both past their limits this step (cost 1 each): a world
    that succeeds at step t pays 3 (T - t) more than one that does not end (the horizon's), a peak cost alone nothing
    more; with the horizon's cost 0 a success pays nothing more (plain Lagrangian: no division)."""
    limits = (Constraint("palm_speed", 1.0, "peak"), Constraint("load", 1.0, "horizon"))
    task = load_task(OBJ, None, backend="mujoco", reward=RewardConfig(constraints=limits))
    task = task.bind(task.data.replace(params=task.data.params.replace(multipliers=jnp.asarray([2.0, 3.0]))))
    T, t = task.config.episode_length, 10
    reward = lambda success, costs: _ending_reward(task, t, costs, success=success)[1]  # noqa: E731
    (won, going), (won_within, going_within) = jax.device_get(jax.jit(lambda: (
        (reward(True, [1.0, 1.0]), reward(False, [1.0, 1.0])), (reward(True, [1.0, 0.0]), reward(False, [1.0, 0.0]))
    ))())
    assert float(going["constraints"]) == pytest.approx(-5.0)
    assert float(won["constraints"]) == pytest.approx(-5.0 - 3.0 * (T - t))
    assert float(won_within["constraints"]) == float(going_within["constraints"]) == pytest.approx(-2.0)


def test_dual_ascent_raises_the_multiplier_over_budget_lowers_it_under_and_keeps_it_in_bounds():
    c = Constraint(budget=0.01, lr=50.0, lambda_max=20.0)
    assert float(multiplier_update(c, 1.0, 0.03)) == pytest.approx(2.0)  # 1 + 50 (0.03 - 0.01)
    assert float(multiplier_update(c, 1.0, 0.0)) == pytest.approx(0.5)  # relaxes once the pull is under budget
    assert float(multiplier_update(c, 0.1, 0.0)) == 0.0 and float(multiplier_update(c, 19.0, 1.0)) == 20.0
    cost = lambda x, cfg=c: float(constraint_cost(cfg, jnp.float32(x)))  # noqa: E731
    assert cost(0.5 * c.limit) == 0.0 and cost(c.limit) == 0.0 and cost(1.5 * c.limit) == pytest.approx(0.5)
    rate = Constraint("palm_speed", 0.25, "rate")
    assert cost(0.25, rate) == 0.0 and cost(0.26, rate) == 1.0 and cost(9.0, rate) == 1.0
    peak = Constraint("palm_speed", 0.25, "peak")  # every step after the episode's first past the limit pays
    assert cost(0.25, peak) == 0.0 and cost(0.26, peak) == 1.0
    assert float(constraint_cost(peak, jnp.float32(0.0), jnp.bool_(True))) == 1.0
    horizon = Constraint("palm_speed", 0.25, "horizon")  # the peak's cost step by step (its charge at success aside)
    assert cost(0.25, horizon) == 0.0 and cost(0.26, horizon) == 1.0
    assert float(constraint_cost(horizon, jnp.float32(0.0), jnp.bool_(True))) == 1.0
    for bad in ({"budget": -0.1}, {"measure": "speed"}, {"cost": "square"}, {"lambda_max": float("inf")}):
        with pytest.raises(DragMeshError, match="constraint"):
            Constraint(**bad)


def test_load_budget_reward_penalises_only_the_pull_beyond_what_the_grasp_holds():
    cfg = method_defaults("pica_grip").task.reward
    assert cfg.w_load > 0 and dataclasses.replace(cfg, w_load=0.0) == RewardConfig()  # only the load term differs
    args = (jnp.zeros(51), jnp.float32(0.05), jnp.float32(0.0), jnp.float32(0.0), jnp.float32(0.0))
    load = lambda f: float(reward_terms(cfg, *args, jnp.asarray([f, 0.0, 0.0]))["load"])  # noqa: E731
    assert load(0.5 * cfg.f_hold) == 0.0 and load(cfg.f_hold) == 0.0
    assert load(2 * cfg.f_hold) == pytest.approx(-cfg.w_load) and load(3 * cfg.f_hold) == pytest.approx(-2 * cfg.w_load)
    assert float(reward_terms(RewardConfig(), *args, jnp.asarray([1e3, 0.0, 0.0]))["load"]) == 0.0  # off in the paper
