"""MJX's buffers are sized from a probe of the expert drag (physics/contacts.py): the probe counts what the C engine
finds, the budget adds a margin, MJX-JAX keeps that many contact slots, and a world that needs more is reported."""

import dataclasses

import jax
import jax.numpy as jnp
import pytest

from dragmesh2_jax.bench import bench_env
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.physics import contacts
from dragmesh2_jax.physics.contacts import ContactBudget
from dragmesh2_jax.physics.mjx_backend import MjxBackend
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.ppo.train import init_jit, make_train, stack_runs, train
from dragmesh2_jax.task.config import TaskConfig
from dragmesh2_jax.task.env import PullTask, contact_budget
from dragmesh2_jax.task.starts import reset_starts
from tests.conftest import TINY_NET


def test_the_probe_counts_the_grasp_and_the_budget_adds_its_margin(drawer_task):
    task = drawer_task
    targets = task.traj.drag_targets(task.config.control_dt)
    n_con, n_efc = contacts.probe(task.scene, reset_starts(task.scene, task.traj, None), targets, task.substeps,
                                  task.config.settle_substeps)
    assert 3 <= n_con <= 40 and n_efc >= contacts.ROWS_PER_CONTACT * n_con  # a grasp, and its rows
    b = ContactBudget.of(n_con, n_efc, candidates=238, limited_dofs=52)
    assert b.contacts % contacts.QUANTUM == 0 and 0 <= b.contacts - (contacts.MARGIN * n_con + contacts.EXTRA) < 16
    assert b.constraints == contacts.ROWS_PER_CONTACT * b.contacts + 52
    assert ContactBudget.of(n_con, n_efc, candidates=10, limited_dofs=52).contacts == 10  # never above what exists
    with pytest.raises(DragMeshError):
        ContactBudget.of(n_con, n_efc, candidates=238, limited_dofs=52, contacts=0)


def test_a_mix_s_budget_holds_each_of_its_objects():
    drawer = ContactBudget.of(20, 90, 238, 4)
    dishwasher = ContactBudget.of(9, 60, 238, 4)
    joined = ContactBudget.joined([drawer, dishwasher])
    assert joined == drawer and dishwasher.contacts < joined.contacts  # the most any of them needs, field by field
    more_rows = dataclasses.replace(drawer, probed_constraints=200)
    assert ContactBudget.joined([dishwasher, more_rows]).probed_constraints == 200


def test_mjx_jax_keeps_the_budget_and_a_full_world_is_an_overflow(drawer_task):
    """The packaged drawer on MJX-JAX: 238 candidate contacts per world, the budget's slots kept
    (``max_contact_points``); with as many slots as the settled grasp has contacts the world is full (an overflow),
    with fewer it cannot even start. Nothing compiles: the bank's states and the check are evaluated as they are."""
    t = drawer_task
    starts = reset_starts(t.scene, t.traj, None)
    budget = lambda n=None: contact_budget(t.scene, t.traj, TaskConfig(contacts=n), starts)  # noqa: E731
    roomy = MjxBackend(t.scene, t.substeps, starts, budget())
    assert roomy.budget.candidates == 238 and roomy.capped
    assert roomy.buffers["contact_slots"] == roomy.budget.contacts < 238
    grasp = roomy.reset_state(roomy.data, 0)
    assert not bool(roomy.overflow(roomy.data, grasp))
    n_grasp = t.scene.settled_state(*starts[0]).ncon
    full = MjxBackend(t.scene, t.substeps, starts, budget(n_grasp))
    assert full.buffers["contact_slots"] == n_grasp and bool(full.overflow(full.data, full.reset_state(full.data, 0)))
    with pytest.raises(DragMeshError, match=f"a start state has {n_grasp} contacts"):
        MjxBackend(t.scene, t.substeps, starts, budget(n_grasp - 1))


def test_an_overflow_is_one_clear_error(drawer_task):
    task = PullTask(drawer_task.scene, drawer_task.traj, TaskConfig(backend="mjx", contacts=40))
    task.check_overflow(0, "evaluation")
    with pytest.raises(DragMeshError, match=r"in 3 world-steps \(evaluation\).*40 contacts.*--task\.contacts"):
        task.check_overflow(3, "evaluation")


class _Overflowing:
    """Wraps an engine: every world-step overflows its buffers (as an MJX world with too few contact slots)."""

    def __init__(self, real):
        self.real = real
        self.budget = ContactBudget.of(4, 16, candidates=238, limited_dofs=52)

    def __getattr__(self, name):
        return getattr(self.real, name)

    def overflow(self, data, ps):
        return jnp.bool_(True)


def test_an_overflow_stops_training_and_a_benchmark_not_only_an_evaluation(drawer_task):
    task = drawer_task.bind(drawer_task.data)
    task.backend = _Overflowing(drawer_task.backend)
    with pytest.raises(DragMeshError, match=r"overflowed in 4 world-steps \(bench env\)"):
        bench_env(task, num_envs=2, steps=2)
    program = make_train(task, dataclasses.replace(TINY_NET, encoder="none"), PPOConfig(num_envs=2, rollout_len=4),
                         "state_only")
    ts = init_jit(program, program.data(), jax.random.PRNGKey(0))
    with pytest.raises(DragMeshError, match=r"overflowed in 8 world-steps \(epoch 1\)"):
        train(program, program.data(1), stack_runs([ts]), 1)


def test_a_hand_pushed_into_a_fixed_part_penetrates_it_and_a_free_hand_does_not(drawer_task):
    """The packaged drawer closed (at its joint's lower limit it cannot go further in: a fixed box). The hand at the
    expert's grasp, its wrist driven 10 cm into the drawer front (the position drives push with up to 300 N),
    penetrates it by millimetres; the same hand lifted 0.5 m clear of the object touches nothing: 0."""
    b = drawer_task.backend
    data, grasp = b.data, b.reset_state(b.data, 0)
    step = jax.jit(lambda ps, ctrl: b.step(data, ps, ctrl, {}))
    start = b.kinematics(data, grasp)
    inward = -start.handle_rot[3:6]  # the handle's outward normal, reversed
    ps = grasp
    for _ in range(15):
        ps = step(ps, start.hand_q.at[:3].add(0.10 * inward))
    pushed = b.kinematics(data, ps)
    assert 0.1 < 1000 * float(pushed.penetration) < 50  # mm
    assert float(pushed.obj_q) == pytest.approx(float(start.obj_q), abs=2e-3)  # the part did not give way
    lifted = grasp.replace(qpos=grasp.qpos.at[data.layout.hand_qpos[2]].add(0.5))
    free = b.kinematics(data, step(lifted, lifted.qpos[data.layout.hand_qpos]))
    assert float(free.penetration) == 0.0
