"""The expert drag as the task reads it (task/expert.py): the residual's prior and the relative load's unit."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.assets.hand import NUM_DOFS, NUM_VIRTUAL
from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.baselines.tracking import tracking_controller
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.evaluate import envelope
from dragmesh2_jax.runs.build import load_task, task_of
from dragmesh2_jax.runs.spec import method_defaults
from dragmesh2_jax.task import expert
from dragmesh2_jax.task.config import Constraint, ResetNoise, RewardConfig, TaskConfig
from dragmesh2_jax.task.env import PullTask, applied_action, make_batched
from dragmesh2_jax.task.expert import LOAD_DAMPINGS, drag_step, expert_replay, load_unit, planned_step, residual_step
from dragmesh2_jax.task.starts import reset_starts

DOOR = str(packaged_object("door_cabinet_0000"))


@pytest.fixture(scope="module")
def door():
    """The packaged door from the expert's exact grasp, its pull bounded by the expert's own (C engine)."""
    bound = RewardConfig(constraints=(Constraint("relative_load", 1.01, "rate"),))
    return load_task(DOOR, None, backend="mujoco", reward=bound)


def test_the_relative_loads_unit_is_the_experts_peak_the_envelope_reports_at_each_damping(door):
    """The probe replays the expert drag at its own pace from the grasp at x1-x8, as the envelope's own cells do; a
    world's unit is interpolated between them in log-damping and held beyond them."""
    rows = envelope(door, paces=(1.0,), dampings=LOAD_DAMPINGS)
    assert door.params.expert_load.shape == (1, len(LOAD_DAMPINGS))  # one row per start: the exact grasp alone
    peaks = np.asarray(door.params.expert_load[0])
    np.testing.assert_allclose(peaks, [r["wrist_load_peak_n"] for r in rows], rtol=1e-3)
    assert rows[0]["opened"] and np.all(peaks > 0)
    unit = jax.vmap(lambda d: load_unit(peaks, d))(jnp.asarray([0.5, 1.0, 2 ** 0.5, 8.0, 16.0]))
    np.testing.assert_allclose(unit, [peaks[0], peaks[0], (peaks[0] + peaks[1]) / 2, peaks[-1], peaks[-1]],
                               rtol=1e-6)


def test_a_task_without_the_measure_does_not_probe_it():
    assert np.isnan(load_task(DOOR, None, backend="mujoco").params.expert_load).all()


def _replay(task, start: int, fixed=None, measure: str = "relative_load"):
    """One episode from bank start ``start`` at x1, the expert drag or the actions ``fixed`` (one for every step, or
    one per step): per step up to the one that ends it, ``measure``'s cost and the critic's last input."""
    step = make_batched(task)[1]
    c = tracking_controller(task)
    policy = c.make_policy(True)
    T = task.config.episode_length
    actions = jnp.broadcast_to(jnp.asarray(0.0 if fixed is None else fixed, jnp.float32), (T, 51))

    def body(s, a):
        s = jax.vmap(task.step_target)(s, policy(c.params, s.obs, None)) if fixed is None else step(s, a[None])
        return s, (s.metrics[f"cost_{measure}"][0], s.done[0], s.obs.privileged[0, -1])

    def run():
        s = jax.vmap(lambda k: task.reset(k, 1.0, start))(jax.random.split(jax.random.PRNGKey(0), 1))
        return jax.lax.scan(body, s, actions)[1]

    cost, done, critic = jax.device_get(jax.jit(run)())
    live = np.cumsum(done) - done == 0  # up to and including the step that ends the episode
    return cost[live], critic[live]


def test_the_expert_replayed_never_pulls_past_its_own_peak_and_a_yank_does(door):
    """At x1 the expert's relative load peaks at 1 (no step past the 1.01 limit); a hand thrown back at full action
    pulls past it."""
    assert _replay(door, 0)[0].max() == 0.0
    yank = np.zeros(51, np.float32)
    yank[:3] = -1.0  # the wrist's translation, full speed one way
    assert _replay(door, 0, yank)[0].max() == 1.0


def test_the_relative_paces_unit_is_the_experts_settled_palm_peak_and_only_a_hurried_palm_passes_it(door):
    """The probe replays the expert drag at x1 from the grasp and keeps the palm's peak speed after the episode's
    first START_STEPS, as the task measures it: replayed through the task the expert's palm never passes 1.01 of it,
    and a wrist thrown back at full action does; a task that bounds no pace probes none."""
    paced = load_task(DOOR, None, backend="mujoco", reward=RewardConfig(constraints=(
        Constraint("relative_palm_speed", 1.01, "rate"),)))
    unit = np.asarray(paced.params.expert_pace)
    assert unit.shape == (1,) and 0.02 < unit[0] < 0.5, unit  # m/s: a hand's pace, not a jolt
    assert _replay(paced, 0, measure="relative_palm_speed")[0].max() == 0.0
    tight = load_task(DOOR, None, backend="mujoco", reward=RewardConfig(constraints=(
        Constraint("relative_palm_speed", 0.98, "rate"),)))
    assert _replay(tight, 0, measure="relative_palm_speed")[0].max() == 1.0  # the unit is the peak, not above it
    yank = np.zeros(51, np.float32)
    yank[:3] = -1.0
    assert _replay(paced, 0, yank, measure="relative_palm_speed")[0].max() == 1.0
    assert np.isnan(door.params.expert_pace).all()
    own = load_task(DOOR, None, backend="mujoco", reward=paced.config.reward, reset_noise=ResetNoise(bank=3),
                    expert_load_unit="start")
    for i in range(3):  # each start held to the expert's own pace from there
        assert _replay(own, i, measure="relative_palm_speed")[0].max() == 0.0


def test_a_peak_cost_charges_every_step_after_the_first_pull_past_the_limit_and_the_critic_sees_it(door):
    """A yank of a few steps, then the hand held: under a rate each step pays only while past the limit, under a
    peak cost every step after the first past it pays, and the privileged critic's last input says so."""
    yank = np.zeros((door.config.episode_length, 51), np.float32)
    yank[4:10, :3] = -1.0  # after four steps held
    rate, _ = _replay(door, 0, yank)
    peak_task = load_task(DOOR, None, backend="mujoco",
                          reward=RewardConfig(constraints=(Constraint("relative_load", 1.01, "peak"),)))
    peak, critic = _replay(peak_task, 0, yank)
    first = int(np.argmax(rate > 0))
    assert first >= 4 and rate.max() == 1.0 and rate[first:].min() == 0.0  # the rate stops once the pull falls back
    assert peak[:first].max() == 0.0 and peak[first:].min() == 1.0
    np.testing.assert_array_equal(critic, peak)


def test_from_its_own_start_each_world_is_held_to_what_the_expert_pulls_there(door):
    """``expert_load_unit="start"``: one row per start of the reset bank, each the expert's peaks from that start
    (probed as a task of its own start), and the expert replayed from any start never past it; the grasp's unit is
    its one row for every start."""
    noise = ResetNoise(bank=3)
    own = load_task(DOOR, None, backend="mujoco", reward=door.config.reward, reset_noise=noise,
                    expert_load_unit="start")
    grasp = load_task(DOOR, None, backend="mujoco", reward=door.config.reward, reset_noise=noise)
    bank = reset_starts(door.scene, door.traj, noise, None, door.config.rho)
    each = [np.asarray(PullTask(door.scene, door.traj, door.config, start=s).params.expert_load[0]) for s in bank]
    np.testing.assert_allclose(own.params.expert_load, each, rtol=1e-6)
    np.testing.assert_allclose(grasp.params.expert_load, np.broadcast_to(door.params.expert_load, (3, 4)), rtol=1e-6)
    assert not np.allclose(each[1], each[2])  # the starts differ, and so do their units
    for i in range(3):
        assert _replay(own, i)[0].max() == 0.0
    with pytest.raises(DragMeshError, match="expert_load_unit"):
        TaskConfig(expert_load_unit="bank")


def test_an_evaluation_counts_no_costs_so_one_probe_from_the_grasp_stands_for_every_start(door):
    """An evaluation's task (its multipliers stay zero) probes the expert once, from the exact grasp, whatever the
    unit; asked to measure the costs (``experiments/load_budget.py``) it probes each start as training does."""
    noise = ResetNoise(bank=3)
    own = load_task(DOOR, None, backend="mujoco", reward=door.config.reward, expert_load_unit="start")
    evaluated, measured = own.with_starts(noise), own.with_starts(noise, costs=True)
    np.testing.assert_array_equal(evaluated.params.expert_load, np.broadcast_to(door.params.expert_load, (3, 4)))
    bank = reset_starts(door.scene, door.traj, noise, None, door.config.rho)
    each = [np.asarray(PullTask(door.scene, door.traj, door.config, start=s).params.expert_load[0]) for s in bank]
    np.testing.assert_allclose(measured.params.expert_load, each, rtol=1e-6)


def test_a_probe_is_kept_and_read_back_and_a_damaged_one_is_probed_again(door, tmp_path, monkeypatch):
    """The probe's replays are deterministic, so every task of the recipe reads them from the cache after the first;
    a cache file cut short is probed again and rewritten."""
    monkeypatch.setenv("DRAGMESH2_CACHE", str(tmp_path))
    first = np.asarray(PullTask(door.scene, door.traj, door.config).params.expert_load)
    (kept,) = (tmp_path / "expert_load").iterdir()
    np.testing.assert_array_equal(np.frombuffer(kept.read_bytes(), np.float32), first[0])
    kept.write_bytes(np.arange(len(LOAD_DAMPINGS), dtype=np.float32).tobytes())  # read back, not replayed
    np.testing.assert_array_equal(PullTask(door.scene, door.traj, door.config).params.expert_load[0],
                                  np.arange(len(LOAD_DAMPINGS)))
    kept.write_bytes(kept.read_bytes()[:5])
    np.testing.assert_array_equal(PullTask(door.scene, door.traj, door.config).params.expert_load, first)
    np.testing.assert_array_equal(np.frombuffer(kept.read_bytes(), np.float32), first[0])


def test_the_drag_step_under_a_lead_is_the_first_planned_past_the_part_and_never_ahead_of_time():
    """prior_lead: the drag's step at most the first whose planned joint lies lead x the range past the part's joint
    (the plan made monotone), never later than the episode step; without a lead, the episode step."""
    params = PullTask.__new__(PullTask)  # only its three fields are read
    params.schedule, params.q_start, params.q_goal = jnp.asarray([0.0, 0.1, 0.3, 0.2, 0.5, 0.7, 0.9, 1.0]), 0.0, 2.0
    lead = TaskConfig(expert_prior=True, prior_lead=0.1)  # 0.2 in joint units
    assert int(drag_step(lead, jnp.int32(7), jnp.float32(0.0), params)) == 2  # planned 0.3 is the first past 0.2
    assert int(drag_step(lead, jnp.int32(7), jnp.float32(0.15), params)) == 4  # 0.3 and the plan's dip held at 0.3
    assert int(drag_step(lead, jnp.int32(1), jnp.float32(0.9), params)) == 1  # a part ahead: the episode's step
    assert int(drag_step(TaskConfig(expert_prior=True), jnp.int32(7), jnp.float32(0.0), params)) == 7
    for bad in ({"prior_lead": 0.1}, {"prior_lead": 0.0, "expert_prior": True}):
        with pytest.raises(DragMeshError, match="prior_lead"):
            TaskConfig(**bad)


def test_the_drag_step_under_a_floor_is_never_behind_the_part():
    """prior_floor: the drag's step at least the first whose planned joint (made monotone) reaches the part's joint,
    the plan's last for a part past it; the episode's step where it is later; under a lead too, at most the lead's."""
    params = PullTask.__new__(PullTask)  # only its three fields are read
    params.schedule, params.q_start, params.q_goal = jnp.asarray([0.0, 0.1, 0.3, 0.2, 0.5, 0.7, 0.9, 1.0]), 0.0, 2.0
    floor = TaskConfig(expert_prior=True, prior_floor=True)
    step = lambda config, k, q: int(drag_step(config, jnp.int32(k), jnp.float32(q), params))  # noqa: E731
    assert step(floor, 1, 0.45) == 4  # a part opened to 0.45: the plan's first step at 0.5, not step 1's 0.1
    assert step(floor, 6, 0.45) == 6  # later in the episode: its own step
    assert step(floor, 0, 5.0) == 7  # past the plan's end: its last step
    both = dataclasses.replace(floor, prior_lead=0.1)  # 0.2 in joint units
    assert step(both, 1, 0.45) == 4 and step(both, 7, 0.0) == 2  # the floor, and the lead's hold on a lagging part
    with pytest.raises(DragMeshError, match="prior_floor"):
        TaskConfig(prior_floor=True)


def test_the_drag_from_the_start_begins_where_the_part_began_and_keeps_its_own_pace_after():
    """prior_from_start: the episode's step after the first whose planned joint (made monotone) reaches the part's
    joint at the episode's start, the plan's last past its end; a part pulled ahead does not move it (prior_floor's
    would, where also set), and a lead still holds it back for a part that lags."""
    params = PullTask.__new__(PullTask)  # only its three fields are read
    params.schedule, params.q_start, params.q_goal = jnp.asarray([0.0, 0.1, 0.3, 0.2, 0.5, 0.7, 0.9, 1.0]), 0.0, 2.0
    start = TaskConfig(expert_prior=True, prior_from_start=True)
    step = lambda config, k, q, q0: int(drag_step(config, jnp.int32(k), jnp.float32(q), params,  # noqa: E731
                                                  planned_step(params, jnp.float32(q0))))
    assert step(start, 0, 0.45, 0.45) == 4 and step(start, 2, 0.45, 0.45) == 6  # from the plan's 0.5 on, step by step
    assert step(start, 1, 0.9, 0.0) == 1  # a part pulled ahead: the drag keeps its pace
    assert step(start, 3, 0.0, 0.8) == 7  # past the plan's end: its last
    assert step(dataclasses.replace(start, prior_lead=0.1), 5, 0.0, 0.0) == 2  # the lead's hold on a lagging part
    assert step(dataclasses.replace(start, prior_floor=True), 1, 0.9, 0.0) == 6  # the floor, also set, still follows
    with pytest.raises(DragMeshError, match="prior_from_start"):
        TaskConfig(prior_from_start=True)


def test_an_eased_residual_offsets_the_drags_target_by_a_share_of_itself_that_grows_to_all_of_it():
    """residual_ramp: the residual's gain rises linearly from the episode's start, 1/R at its first step, whole from
    step R - 1 on; the output charged is the policy's own, as it chose it."""
    params = PullTask.__new__(PullTask)  # only the fields residual_step reads
    params.drag, params.hand_lo, params.hand_hi = jnp.zeros((8, 51)), -jnp.ones(51), jnp.ones(51)
    params.schedule, params.q_start, params.q_goal = jnp.linspace(0.0, 1.0, 8), 0.0, 1.0
    config = TaskConfig(expert_prior=True, residual_on="target", residual_ramp=4)
    a = jnp.full(51, 0.8)
    offset = lambda k: float(residual_step(config, params, {"step": jnp.int32(k)}, jnp.zeros(51), jnp.float32(0.0),  # noqa: E731
                                           a)[0][0])
    whole = config.alpha * 0.8
    assert offset(0) == pytest.approx(whole / 4) and offset(1) == pytest.approx(whole / 2)
    assert offset(3) == pytest.approx(whole) and offset(6) == pytest.approx(whole)
    assert float(residual_step(config, params, {"step": jnp.int32(0)}, jnp.zeros(51), jnp.float32(0.0), a)[2][0]) == \
        pytest.approx(0.8)
    for bad in ({"residual_ramp": 4}, {"residual_ramp": -1, "expert_prior": True}):
        with pytest.raises(DragMeshError, match="residual_ramp"):
            TaskConfig(**bad)


def test_a_residual_scope_narrows_its_leading_channels_and_leaves_the_rest_whole():
    """"translation" narrows the wrist's pull, "wrist" its pull and turn (the grasp free), "hand" every channel."""
    for scope, narrowed in (("translation", 3), ("wrist", NUM_VIRTUAL), ("hand", NUM_DOFS)):
        gain = expert.residual_gain(TaskConfig(expert_prior=True, residual_scale=0.125, residual_scope=scope))
        assert gain.shape == (NUM_DOFS,) and (gain[:narrowed] == 0.125).all() and (gain[narrowed:] == 1.0).all()


def test_a_prior_with_a_floor_does_not_push_a_part_open_start_back(door):
    """From a start with the door part-open, at x8, the time-indexed drag's first targets are the closed door's
    grasp, so its prior pushes the door back; with prior_floor (or prior_from_start) the hand's target starts where
    the door is."""
    noise = ResetNoise(wrist_pos=0.0, wrist_rot=0.0, fingers=0.0, object_q=0.5, bank=1, seed=3)
    config = dataclasses.replace(door.config, expert_prior=True, residual_on="target", reset_noise=noise)
    timed = PullTask(door.scene, door.traj, config)
    floored = PullTask(door.scene, door.traj, dataclasses.replace(config, prior_floor=True))
    from_start = PullTask(door.scene, door.traj, dataclasses.replace(config, prior_from_start=True))

    def run(task):
        s = task.reset(jax.random.PRNGKey(0), jnp.float32(8.0))
        q0 = task.kinematics(s).obj_q
        return jax.lax.scan(lambda s, _: (s := task.step(s, jnp.zeros(51)), s.metrics["q"] - q0), s, None,
                            length=12)[1]

    back_timed, back_floored, back_from = jax.device_get(jax.jit(lambda: (run(timed), run(floored),
                                                                         run(from_start)))())
    assert back_timed.min() < -0.01 and back_floored.min() > -0.002, (back_timed.min(), back_floored.min())
    assert back_from.min() > -0.002, back_from.min()


def test_a_yielding_prior_waits_for_a_part_that_lags_and_follows_one_that_keeps_up(door):
    """The residual's prior with prior_lead: where the part keeps up (x1, a lead it never reaches) zeros replay the
    expert's drag exactly; where it lags (x200 damping) the hand's target waits for it: the prior's pull (its applied
    action on the wrist's translation) stays well short of the time-indexed drag's, which runs on ahead."""
    timed = PullTask(door.scene, door.traj, dataclasses.replace(door.config, expert_prior=True))
    far = PullTask(door.scene, door.traj, dataclasses.replace(timed.config, prior_lead=10.0))
    near = PullTask(door.scene, door.traj, dataclasses.replace(timed.config, prior_lead=0.05))

    def run(task, damping):
        s = task.reset(jax.random.PRNGKey(0), jnp.float32(damping))
        s, pull = jax.lax.scan(lambda s, _: (s := task.step(s, jnp.zeros(51)),
                                             jnp.linalg.norm(applied_action(s.obs, 51)[:3])), s, None, length=120)
        return s.metrics["q"], pull[90:].mean()

    (q_timed, _), (q_far, _), (_, pull_timed), (_, pull_near) = jax.device_get(jax.jit(lambda: (
        run(timed, 1.0), run(far, 1.0), run(timed, 200.0), run(near, 200.0)))())
    assert q_far == pytest.approx(q_timed, abs=1e-6)
    assert pull_near < 0.5 * pull_timed


def test_a_residual_on_the_target_replays_the_drag_as_pd_targets_and_is_charged_only_for_its_own_output(door):
    """residual_on "target": zeros put the hand's PD target on the drag's (the tracking baseline, frame for frame),
    where the residual on the action cuts it to alpha from the hand; at x200 damping the hand lags, the applied action
    saturates and the wrist's target leads the hand further (its pull), while PICA's bound term reads the policy's
    zeros (the action residual's, the saturated sum)."""
    on_action = PullTask(door.scene, door.traj, dataclasses.replace(door.config, expert_prior=True))
    on_target = PullTask(door.scene, door.traj, dataclasses.replace(on_action.config, residual_on="target"))
    drag = on_target.params.drag

    def run(task, damping, targets=False):
        s = task.reset(jax.random.PRNGKey(0), jnp.float32(damping))

        def body(s, _):
            s = task.step_target(s, drag[s.info["step"]]) if targets else task.step(s, jnp.zeros(51))
            return s, (s.metrics["q"], s.info["ctrl"], jnp.abs(applied_action(s.obs, 51)).max(),
                       s.metrics["reward/bound"], jnp.linalg.norm(s.info["ctrl"][:3] - task.kinematics(s).hand_q[:3]))
        return jax.lax.scan(body, s, None, length=90)[1]

    (q_t, ctrl_t, _, _, _), (q_pd, _, _, _, _), (_, _, sat_t, bound_t, pull_t), (_, _, sat_a, bound_a, pull_a) = \
        jax.device_get(jax.jit(lambda: (run(on_target, 1.0), run(on_target, 1.0, True), run(on_target, 200.0),
                                        run(on_action, 200.0)))())
    lo, hi = np.asarray(on_target.params.hand_lo), np.asarray(on_target.params.hand_hi)
    np.testing.assert_allclose(ctrl_t, np.clip(np.asarray(drag)[:90], lo, hi), atol=1e-6)
    np.testing.assert_array_equal(q_t, q_pd)
    assert sat_t[60:].max() > 0.99 and sat_a[60:].max() > 0.99  # the hand lags its target by more than alpha
    assert np.all(bound_t == 0.0) and bound_a.min() < 0.0
    assert pull_t[60:].mean() > 1.5 * pull_a[60:].mean()
    with pytest.raises(DragMeshError, match="residual_on"):
        TaskConfig(residual_on="target")


def test_on_the_hands_contacts_the_recipes_grip_holds_the_packaged_drawers_bar_within_2_mm():
    """The expert grasp the recipe's structure holds with (seated, ranked by the load it holds), its drag replayed at
    x1 and x8 from the exact grasp: on the hand's contacts (the firm grip's scene) the deepest hand-object contact
    stays within 2 mm; on MuJoCo's default object contacts, which a contact averages with the hand's, the same grip
    sinks past 4 mm."""
    recipe = method_defaults("hold_blind_residual_grip")
    deepest = {}
    for contacts in ("hand", "mujoco"):
        scene = dataclasses.replace(recipe.scene, object_contact=contacts)
        task = task_of(str(packaged_object("drawer_cabinet_0000")), None,
                       dataclasses.replace(recipe.task, backend="mujoco"), scene)
        assert task.traj.header["generator"]["seated"]
        deepest[contacts] = [expert_replay(task.scene, task.traj, task.config, task.substeps, d).deepest
                             for d in (1.0, 8.0)]
    assert max(deepest["hand"]) <= 0.002 and min(deepest["mujoco"]) > 0.004
