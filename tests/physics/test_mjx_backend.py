"""MJX's Warp implementation as a tested engine on a CPU (its kernels run there too): the expert drag's verdicts and
the contact-load sensors agree with the C engine, PPO trains on it (the model is data, seeds vmap as one program; a
run that records its buffers: tests/runs/test_generalist.py), each world's damping reaches its physics, and a buffer
too small for the contacts is reported, never dropped. One worker runs them all: Warp compiles its kernels once per
process (and caches them on disk)."""

import subprocess
import sys

import jax
import numpy as np
import pytest

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.baselines.tracking import tracking_controller
from dragmesh2_jax.bench import buffers
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.evaluate import track
from dragmesh2_jax.evaluation.rollout import rollout
from dragmesh2_jax.ppo.train import epoch_jit, epoch_runs, init_jit, init_runs, make_train, policy_params, seed_keys
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.runs.presets import RECOMMENDED
from dragmesh2_jax.scene import SceneConfig, build_scene
from dragmesh2_jax.task.env import PullTask
from dragmesh2_jax.trajectory.generator import generate
from tests.conftest import REAL_OBJECTS, require_warp, tiny_program
from tests.task.conftest import PARITY_STEPS, assert_bounded_divergence, assert_loads_agree, expert_trace
from tests.task.test_contact_load import forces

pytestmark = [pytest.mark.xdist_group("warp"), pytest.mark.long]
OBJ = str(default_object())
#: The shared object whose expert drag Warp runs to each episode's end (the others: PARITY_STEPS), the door whose
#: verdicts differ most across dampings.
WARP_EPISODE_OBJECT = "45780"
#: Control steps of its episodes: the C engine's end (opened) at steps 101 / 105 / 115 at x1 / x2 / x4, and a Warp
#: episode that needed a third longer would not count as the same verdict.
WARP_EPISODE_STEPS = 150
DAMPINGS = [1.0, 2.0, 4.0]


@pytest.fixture(scope="module", autouse=True)
def _warp():
    require_warp()


def _warp_task(obj, traj=None, **task):
    return load_task(obj, traj, backend="mjx", impl="warp", **task)


@pytest.mark.parametrize("oid", REAL_OBJECTS)
def test_the_expert_drag_agrees_with_the_c_engine(gapartnet_dir, real_objects, oid):
    """The expert drag from the exact start at x1/x2/x4 on every shared object: its first second within MJX-JAX's
    bounds of the C engine's (tests/task/test_tracking.py); on WARP_EPISODE_OBJECT each episode to its end, opened (or
    not) on Warp where it is on the C engine."""
    traj = generate(real_objects[oid])
    traces = {engine: expert_trace(task, WARP_EPISODE_STEPS if oid == WARP_EPISODE_OBJECT else PARITY_STEPS)
              for engine, task in (("mujoco", load_task(str(gapartnet_dir / oid), traj, backend="mujoco")),
                                   ("warp", _warp_task(str(gapartnet_dir / oid), traj)))}
    assert_bounded_divergence(traces, real_objects[oid].target.joint.is_revolute, engine="warp")
    if oid == WARP_EPISODE_OBJECT:
        verdicts = {b: list(t["success"]) for b, t in traces.items()}
        assert verdicts["warp"] == verdicts["mujoco"] and verdicts["warp"][0]


def test_the_buffers_are_mjx_jaxs_and_the_budgets():
    """What ``bench env`` reports of Warp's buffers at 16 worlds (tests/test_bench.py runs the C engine and MJX-JAX
    in a fresh process): the contact slots MJX-JAX holds, capped below the probe's candidates, and the constraint rows
    of the budget."""
    wp = buffers(_warp_task(OBJ).sized(16))
    jx = buffers(load_task(OBJ, backend="mjx").sized(16))
    assert wp["contact_slots"] == jx["contact_slots"] < wp["budget"]["candidates"]
    assert wp["constraint_rows"] == wp["budget"]["constraints"]


def test_contact_sensors_agree_with_the_c_engine():
    """Same start, zero actions, 10 control steps: MJX-JAX's tolerance (tests/task/conftest.assert_loads_agree): wrist
    force within 2 N + 15%, summed palm/phalanx normal force within 20% + 1 N."""
    assert_loads_agree(*(forces(t)[0] for t in (load_task(OBJ, None, backend="mujoco", force_obs=True),
                                                _warp_task(OBJ, force_obs=True))))


def test_each_worlds_damping_reaches_its_physics():
    """The same expert targets in worlds at x1 and x8: the stiffer part has opened less after 60 steps."""
    task = _warp_task(OBJ)
    c = tracking_controller(task)
    q = rollout(task, c.make_policy(True), c.params, [1.0, 8.0], controls=c.controls, steps=60, key=c.key)["q"][-1]
    assert q[0] > q[1] + 1e-3 > task.traj.q_start + 1e-3


def test_a_buffer_too_small_for_the_contacts_is_an_error():
    """Room for the grasp's contacts but not for the drag's (the probe finds more as the hand pulls): the
    evaluation stops with the overflow; room for fewer than the grasp's: the task cannot be built."""
    task = _warp_task(OBJ)
    grasp = task.scene.settled_state(task.traj.frames[task.traj.drag_start].hand_q,
                                     task.traj.target_q[task.traj.drag_start]).ncon
    assert task.backend.budget.probed_contacts > grasp
    with pytest.raises(DragMeshError, match="overflowed in .* world-steps \\(evaluation\\)"):
        track(_warp_task(OBJ, contacts=grasp), [1.0])
    with pytest.raises(DragMeshError, match=f"a start state has {grasp} contacts"):
        _warp_task(OBJ, contacts=grasp - 1)


def test_the_model_is_data_same_object_other_damping_shares_the_program():
    """On MJX the model's static fields (geometry and the contact budget included) fix the program; the nominal
    damping is data (an argument, as on MJX-JAX). The program is the load-aware preset's (force-aware observation,
    privileged critic): those train on MJX too."""
    obj = load_gapartnet(OBJ)
    base = tiny_program(RECOMMENDED, backend="mjx", impl="warp")
    tasks = [PullTask(build_scene(obj, SceneConfig(damping=damping)), base.task.traj, base.task.config)
             for damping in (10.0, 40.0)]
    assert tasks[0].backend.budget.contacts == tasks[1].backend.budget.contacts
    programs = [make_train(t, base.network, base.config, base.name) for t in tasks]

    def first_epoch(p):
        return epoch_jit(p, p.data(), init_jit(p, p.data(), jax.random.PRNGKey(0)))[0]

    ts = first_epoch(programs[0])
    compiled = epoch_jit._cache_size()
    first_epoch(programs[1])
    assert epoch_jit._cache_size() == compiled  # the other damping found the program compiled
    damping = [float(p.task.data.physics.model.dof_damping[p.task.scene.ids.target_dof]) for p in programs]
    assert damping == [10.0, 40.0]
    assert int(ts.epoch) == 1 and float(ts.privileged_stats.count) > 1
    a = programs[0].make_policy(True)(policy_params(ts), ts.env_state.obs, jax.random.PRNGKey(0))
    assert a.shape == (base.config.num_envs, 51) and np.isfinite(np.asarray(a)).all()


def test_seeds_as_one_program_equal_separate_runs():
    """Two seeds vmapped over a run axis (each world's buffer share sized for both runs' worlds) give each seed's
    separate epoch."""
    p = tiny_program(RECOMMENDED, backend="mjx", impl="warp")
    both = epoch_runs(p, p.data(2), init_runs(p, p.data(2), seed_keys([0, 1])))[1]["loss"]
    alone = [float(epoch_jit(p, p.data(), init_jit(p, p.data(), seed_keys([s])[0]))[1]["loss"]) for s in (0, 1)]
    np.testing.assert_allclose(np.asarray(both), alone, rtol=2e-3, atol=2e-3)


#: A fresh process that starts as ``dragmesh2`` does for a command on MJX (the CLI pins JAX's CPU pool before anything
#: starts JAX: ``engines.avoid_lapack_deadlock``), then runs two batched Cholesky factorisations in one program,
#: as MJX-JAX's Newton solver and implicitfast integrator do from about 5 worlds. jaxlib 0.10's CPU LAPACK kernels
#: deadlock on them on a 2-thread pool: without the pin (the same process on ``--backend mujoco``) it hangs.
LAPACK_PROBE = """
import jax
import jax.numpy as jnp

from dragmesh2_jax.cli import main

assert main(["bench", "env", "--backend", "mjx", "--objects", "/nonexistent/object"]) == 2  # past the CLI's start
m = jax.random.normal(jax.random.PRNGKey(0), (64, 128, 128))
spd = m @ jnp.swapaxes(m, -1, -2) + 128 * jnp.eye(128)
both = jax.jit(lambda x, y: jnp.linalg.cholesky(x).sum() + jnp.linalg.cholesky(y).sum())
for i in range(20):
    jax.block_until_ready(both(spd, 2 * spd + i))
print("factorised")
"""
LAPACK_PROBE_TIMEOUT_S = 120  # it finishes in ~10 s; a deadlock never does


def test_a_cli_process_on_mjx_factorises_batches_without_deadlock():
    done = subprocess.run([sys.executable, "-c", LAPACK_PROBE], capture_output=True, text=True,
                          timeout=LAPACK_PROBE_TIMEOUT_S)
    assert done.returncode == 0 and "factorised" in done.stdout, done.stderr[-2000:]
