"""The pulling task: API shapes, damping, aux targets, termination vs truncation, robustness, bad config."""

import dataclasses
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.baselines.parallel_jaw import parallel_jaw
from dragmesh2_jax.baselines.tracking import tracking_delta_controller
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.task import randomize
from dragmesh2_jax.task.config import TaskConfig
from dragmesh2_jax.task.env import AUX_SIZE, TOKEN_SIZE, PullTask, applied_action, make_batched
from dragmesh2_jax.task.observation import STATE_SIZE
from dragmesh2_jax.task.protocol import METRICS, observation_spec
from dragmesh2_jax.task.rewards import TERM_PREFIX, term_names
from dragmesh2_jax.task.wrappers import AutoReset
from dragmesh2_jax.trajectory.schema import read_trajectory


def _task(base: PullTask, **changes) -> PullTask:
    return PullTask(base.scene, base.traj, dataclasses.replace(base.config, **changes))


def _rollout(task, actions, scales, seed=0):
    reset, step = make_batched(AutoReset(task))
    n = len(scales)
    state = jax.jit(reset)(jax.random.split(jax.random.PRNGKey(seed), n), jnp.asarray(scales, jnp.float32))
    first = state

    def body(s, a):
        s = step(s, a)
        return s, (s.metrics, s.obs, s.done, s.terminated, s.truncated)

    _, out = jax.jit(lambda s, a: jax.lax.scan(body, s, a))(state, actions)
    return first, out


def test_reset_and_step_shapes_and_dtypes(drawer_task):
    """The env protocol: the observation spec without running, every metric name, multipliers per world."""
    spec = observation_spec(drawer_task)
    assert spec.state.shape == (STATE_SIZE,) and spec.history.shape == (16, TOKEN_SIZE)
    assert spec.aux.shape == (AUX_SIZE,)
    reset, step = make_batched(drawer_task)
    s = jax.jit(reset)(jax.random.split(jax.random.PRNGKey(0), 3))
    assert s.obs.state.shape == (3, STATE_SIZE) and s.obs.history.shape == (3, 16, TOKEN_SIZE)
    s = jax.jit(step)(s, jnp.zeros((3, 51)))
    assert s.obs.state.dtype == jnp.float32 and s.reward.shape == (3,) and s.done.dtype == jnp.bool_
    terms = {TERM_PREFIX + t for t in term_names(drawer_task.config.reward)}
    assert set(s.metrics) == set(METRICS) | terms
    # every term of r_t is a metric of the step, and they sum to it
    np.testing.assert_allclose(sum(s.metrics[t] for t in terms), s.reward, rtol=1e-5, atol=1e-6)
    # training damping is sampled per world from [1, 2]
    sc = np.asarray(s.info["scales"][randomize.DAMPING])
    assert np.all((sc >= 1) & (sc <= 2)) and len(set(sc.tolist())) == 3
    # the newest history token is [e_t, a_{t-1}] with the action just applied
    np.testing.assert_allclose(s.obs.history[:, -1, 51:], 0.0)


def test_a_log_uniform_damping_puts_as_many_worlds_in_each_doubling():
    """``damping_log`` draws the multiplier log-uniform over [1, 8]: a third of the worlds in each of [1, 2], [2, 4] and
    [4, 8] (uniform puts a seventh below x2); a range reaching 0 cannot be drawn so."""
    keys = jax.random.split(jax.random.PRNGKey(0), 6000)

    def draws(log):
        config = TaskConfig(damping_range=(1.0, 8.0), damping_log=log)
        return np.asarray(jax.vmap(lambda k: randomize.sample(k, config)[randomize.DAMPING])(keys))

    log, flat = draws(True), draws(False)
    assert log.min() >= 1.0 and log.max() <= 8.0
    np.testing.assert_allclose([np.mean(log < 2), np.mean((log >= 2) & (log < 4)), np.mean(log >= 4)], 1 / 3, atol=0.03)
    assert np.mean(flat < 2) == pytest.approx(1 / 7, abs=0.03)
    with pytest.raises(DragMeshError, match="damping_log"):
        TaskConfig(damping_range=(0.0, 8.0), damping_log=True)


def test_expert_grasp_state_at_reset(drawer_task):
    s = drawer_task.reset(jax.random.PRNGKey(0))
    q0 = drawer_task.traj.frames[drawer_task.traj.drag_start].hand_q
    np.testing.assert_allclose(s.obs.state[:51], q0, atol=0.02)  # 4 settle substeps from rest
    assert float(s.obs.state[114]) <= drawer_task.config.d_detach  # armed: the palm starts at the handle
    assert bool(s.info["armed"])
    np.testing.assert_allclose(s.obs.history[:-1], 0.0)


def _pull_actions(task, steps, n):
    """Pull the wrist outwards along the handle normal at full speed."""
    a = np.zeros((steps, n, 51), np.float32)
    a[:, :, :3] = task.scene.handle.normal
    return jnp.asarray(a)


def test_higher_damping_means_less_motion(drawer_task):
    task = _task(drawer_task, episode_length=1000)
    _, (m, *_) = _rollout(task, _pull_actions(task, 20, 2), [1.0, 8.0])
    q = np.asarray(m["q"])
    assert q[-1, 0] > q[-1, 1] + 1e-3 > 1e-3


def test_aux_targets_match_numpy_reference(drawer_task):
    task = _task(drawer_task, episode_length=1000)
    rng = np.random.default_rng(0)
    actions = jnp.asarray(rng.uniform(-0.3, 0.3, (12, 1, 51)).astype(np.float32))
    first, (m, obs, *_) = _rollout(task, actions, [1.0])
    K = task.config.aux_window
    d = np.concatenate([[float(first.obs.state[0, 114])], np.asarray(m["palm_dist"])[:, 0]])
    q = np.concatenate([[float(first.metrics["q"][0])], np.asarray(m["q"])[:, 0]])
    e0 = np.linalg.norm(np.asarray(first.obs.history[0, -1, :51]))
    e = np.concatenate([[e0], np.linalg.norm(np.asarray(obs.history)[:, 0, -1, :51], axis=-1)])
    aux = np.asarray(obs.aux)[:, 0]
    for t in range(1, len(d)):
        w = slice(max(0, t - K), t + 1)  # the window is seeded with the reset value
        ref = [q[t] - q[max(0, t - K)], d[w].max(), float(d[w].max() > task.config.d_detach), e[w].max()]
        np.testing.assert_allclose(aux[t - 1], ref, rtol=1e-5, atol=1e-6)
    # aux targets are not part of the state observation
    assert obs.state.shape[-1] == STATE_SIZE


def test_time_limit_is_a_truncation_not_a_termination(drawer_task):
    task = _task(drawer_task, episode_length=5)
    _, (m, obs, done, term, trunc) = _rollout(task, jnp.zeros((6, 1, 51)), [1.0])
    assert np.asarray(done)[:, 0].tolist() == [False] * 4 + [True, False]
    assert np.asarray(trunc)[4, 0] and not np.asarray(term)[4, 0]
    assert float(m["episode_length"][4, 0]) == 5


def test_detachment_terminates_after_contact(drawer_task):
    task = _task(drawer_task, episode_length=1000)
    a = -_pull_actions(task, 40, 1)  # push the wrist back into... away from the handle: reverse the normal
    a = a.at[:, :, :3].set(jnp.asarray([0.0, 0.0, 1.0]))  # lift straight up, off the handle
    _, (m, obs, done, term, trunc) = _rollout(task, a, [1.0])
    det = np.asarray(m["detach"])[:, 0]
    assert det.max() == 1.0
    k = int(np.argmax(det))
    assert np.asarray(term)[k, 0] and not np.asarray(trunc)[k, 0]
    assert float(m["reward"][k, 0]) < -40  # the one-shot detachment penalty
    assert float(m["palm_dist"][k, 0]) > task.config.d_detach


def test_random_actions_stay_finite_from_x1_to_x8(drawer_task):
    task = _task(drawer_task)
    rng = np.random.default_rng(1)
    scales = [1.0, 2.0, 4.0, 8.0]
    actions = jnp.asarray(rng.uniform(-1, 1, (300, len(scales), 51)).astype(np.float32))
    _, (m, obs, *_) = _rollout(task, actions, scales)
    assert np.isfinite(np.asarray(obs.state)).all() and np.isfinite(np.asarray(m["reward"])).all()
    assert np.asarray(m["nonfinite"]).sum() == 0


def test_non_finite_world_is_reset_and_counted_without_poisoning_others(drawer_task):
    task = _task(drawer_task, episode_length=1000)
    real = task.backend

    class Poison:
        """Wraps the backend: world whose damping is 8x goes NaN."""

        name, scene, substeps = real.name, real.scene, real.substeps
        reset_state, kinematics, overflow, sized = real.reset_state, real.kinematics, real.overflow, real.sized

        def step(self, data, ps, ctrl, fields):
            out = real.step(data, ps, ctrl, fields)
            bad = fields["dof_damping"][data.layout.target_dof] > 50
            return jax.tree.map(lambda x: jnp.where(bad, jnp.nan, x), out)

    task.backend = Poison()
    _, (m, obs, done, term, _) = _rollout(task, jnp.zeros((3, 2, 51)), [1.0, 8.0])
    assert np.asarray(m["nonfinite"])[:, 1].tolist() == [1.0, 1.0, 1.0]
    assert np.asarray(m["nonfinite"])[:, 0].sum() == 0 and np.isfinite(np.asarray(obs.state)).all()
    assert np.asarray(term)[:, 1].all() and float(np.abs(np.asarray(m["reward"])[:, 1]).max()) == 0.0


@pytest.mark.parametrize("change, fragment", [
    ({"alpha": 0.0}, "alpha"), ({"backend": "cuda"}, "unknown backend"), ({"impl": "torch"}, "impl"),
    ({"damping_range": (2.0, 1.0)}, "damping_range"), ({"residual_scale": 0.5}, "only with expert_prior"),
    ({"residual_scale": 0.0, "expert_prior": True}, "residual_scale"),
    ({"residual_scope": "fingers", "expert_prior": True}, "residual_scope"),
])
def test_bad_config_is_rejected_before_compiling(change, fragment):
    with pytest.raises(DragMeshError, match=fragment):
        TaskConfig(**change)


def test_rho_sets_the_success_threshold(drawer_task):
    """q_done = q_min + rho (q_max - q_min) over the trajectory: --task.rho reaches the task."""
    t = drawer_task.traj
    for rho in (0.5, 0.8):
        task = _task(drawer_task, rho=rho)
        assert float(task.params.q_done) == pytest.approx(t.q_min + rho * (t.q_max - t.q_min), rel=1e-6)
    assert float(_task(drawer_task, rho=0.8).params.q_done) > float(drawer_task.params.q_done)


def test_each_randomised_field_is_one_entry_and_reaches_only_its_field(drawer_task):
    """world_fields: the damping multiplier scales the target joint's damping only, the friction multiplier the
    object's colliding geoms' sliding friction only."""
    d, L = drawer_task.data, drawer_task.data.physics.layout
    fields = randomize.world_fields({"damping_scale": jnp.float32(3.0), "friction_scale": jnp.float32(0.5)},
                                    d.fields, d.params.damping, L)
    assert set(fields) == set(randomize.FIELDS) == {r.field for r in randomize.RANDOMIZERS}
    damp = np.asarray(fields["dof_damping"])
    assert damp[int(L.target_dof)] == pytest.approx(3.0 * float(d.params.damping))
    others = np.arange(len(damp)) != int(L.target_dof)
    np.testing.assert_array_equal(damp[others], np.asarray(d.fields["dof_damping"])[others])
    fr, fr0 = np.asarray(fields["geom_friction"]), np.asarray(d.fields["geom_friction"])
    obj = np.asarray(L.object_geoms)
    np.testing.assert_allclose(fr[obj, 0], 0.5 * fr0[obj, 0])
    np.testing.assert_array_equal(fr[~obj], fr0[~obj])


def test_trajectory_of_another_object_is_rejected(drawer_task, shared_dir):
    other = read_trajectory(shared_dir / "reference" / "trajectories" / "45661.json")
    with pytest.raises(DragMeshError, match="object joints|moves joint"):
        PullTask(drawer_task.scene, other, drawer_task.config)


def test_a_task_on_the_c_engine_never_imports_mjx():
    """MJX is imported when a task chooses it: a process that steps the C engine (a CLI command, CPU training) does not
    pay for MuJoCo Warp's kernels (a fresh process, since this one may have imported MJX already)."""
    code = ("import sys; from dragmesh2_jax.cli import main; from dragmesh2_jax.runs.build import load_task; "
            "from dragmesh2_jax.assets.procedural import default_object; "
            "load_task(str(default_object()), None, backend='mujoco').reset(__import__('jax').random.PRNGKey(0)); "
            "print('mujoco.mjx' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().splitlines()[-1] == "False"


def test_under_the_expert_prior_a_zero_action_replays_the_expert_drag(drawer_task):
    """expert_prior: the applied action is the policy's plus the tracking_delta baseline's, so zeros follow the drag
    exactly as that baseline does (the same part and hand motion, the same applied action in the history: what the
    evaluation's smoothness reads), and a policy's action moves the hand off it, by residual_scale of it on the channels
    of residual_scope (the whole hand, or the wrist's translation alone)."""
    prior = _task(drawer_task, expert_prior=True)
    delta = tracking_delta_controller(drawer_task)
    policy = delta.make_policy(True)
    steps = 60

    def run(task, act):
        s = task.reset(jax.random.PRNGKey(0), jnp.float32(1.0))

        def body(s, _):
            s = task.step(s, act(s))
            return s, (s.metrics["q"], task.kinematics(s).hand_q, applied_action(s.obs, task.action_size))

        return jax.lax.scan(body, s, None, length=steps)[1]

    fine = _task(drawer_task, expert_prior=True, residual_scale=0.5)
    pull = _task(drawer_task, expert_prior=True, residual_scale=0.5, residual_scope="translation")
    (q_delta, h_delta, a_delta), (q_zero, h_zero, a_zero), (_, h_push, _), (_, h_fine, _), (_, h_pull, _) = \
        jax.device_get(jax.jit(lambda: (
            run(drawer_task, lambda s: policy(delta.params, s.obs, None)), run(prior, lambda s: jnp.zeros(51)),
            run(prior, lambda s: jnp.full(51, 0.5)), run(fine, lambda s: jnp.full(51, 2.0)),
            run(pull, lambda s: jnp.full(51, 0.5).at[:3].set(2.0))))())
    np.testing.assert_allclose(q_zero, q_delta, atol=1e-5)
    np.testing.assert_allclose(h_zero, h_delta, atol=1e-5)
    np.testing.assert_allclose(a_zero, a_delta, atol=1e-4)
    assert np.abs(a_zero).max() > 0.1  # the prior's own action, not the policy's zeros
    assert q_zero[-1] > q_zero[0] + 0.1 * float(prior.params.q_goal - prior.params.q_start)  # the drag opens it
    assert np.abs(h_push - h_zero).max() > 0.01
    np.testing.assert_allclose(h_fine, h_push, atol=1e-5)  # at residual_scale 0.5, 2 (clipped to 1) moves as 0.5
    np.testing.assert_allclose(h_pull, h_push, atol=1e-5)  # only the translation's 2 narrowed to 0.5
    assert drawer_task.params.drag.shape == (0,) and prior.params.drag.shape == (prior.config.episode_length, 51)
    with pytest.raises(DragMeshError, match="expert_prior needs the hand"):
        parallel_jaw(prior)
