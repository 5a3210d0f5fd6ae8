"""Where a load-bounded policy spends its budget (experiments/load_budget.py): the share of steps past the
object's expert unit and the mean excess past it, per damping."""

import importlib.util
from pathlib import Path

import jax.numpy as jnp
import pytest

from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.baselines.tracking import tracking_controller
from dragmesh2_jax.policies.controller import Controller
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.task.config import Constraint, ResetNoise, RewardConfig

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "load_budget.py"
_spec = importlib.util.spec_from_file_location("load_budget", SCRIPT)
load_budget = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(load_budget)

BOUND = RewardConfig(constraints=(Constraint("relative_load", 1.0, "rate"),))
DOOR = str(packaged_object("door_cabinet_0000"))


def test_the_expert_from_its_own_grasp_spends_nothing_and_from_perturbed_starts_it_is_measured():
    """The unit is the expert's own peak from its exact grasp: replayed from there it opens the door and is never
    more than a rounding past it; from perturbed starts each share is a fraction of live steps."""
    exact = load_task(DOOR, None, backend="mujoco", reward=BOUND)
    rows = load_budget.spend(exact, tracking_controller(exact), [1.0, 8.0], 1)
    assert [r["damping"] for r in rows] == [1.0, 8.0]
    for r in rows:
        assert r["success"] == 1.0 and r["excess"] < 1e-3
        assert r["unit_n"] == pytest.approx(float(exact.params.expert_load[0, 0 if r["damping"] == 1.0 else -1]))
    perturbed = exact.with_starts(ResetNoise())
    for r in load_budget.spend(perturbed, tracking_controller(perturbed), [1.0], 4):
        assert 0.0 <= r["rate"] <= 1.0 and 0.0 <= r["early_share"] <= 1.0 and r["excess"] >= 0.0


def test_a_residual_policy_s_own_pull_is_its_translation_action_at_the_drives_stiffness():
    """A residual policy (expert_prior) that always asks 0.6 action units along x and 0.8 along y (|u| = 1) at
    residual_scale 0.5 moves the target 0.5 x alpha from the drag's: kp x 0.5 x alpha newtons at the translation
    drives' stiffness kp; the expert drag, not a residual, adds none."""
    task = load_task(DOOR, None, backend="mujoco", reward=BOUND, expert_prior=True, residual_scale=0.5)
    u = jnp.zeros(task.action_size).at[0].set(0.6).at[1].set(0.8)

    def policy(params, obs, key):
        return jnp.broadcast_to(params, (len(obs.state), task.action_size))

    constant = Controller("constant", lambda det: policy, u)
    (row,) = load_budget.spend(task, constant, [1.0], 1)
    want = task.scene.config.hand.virtual.kp * 0.5 * task.config.alpha
    assert row["residual_pull_p95_n"] == pytest.approx(want, rel=1e-5)
    (expert,) = load_budget.spend(task, tracking_controller(task), [1.0], 1)
    assert expert["residual_pull_p95_n"] == 0.0
