"""Several objects in one batch (task/mix.py): each world draws an object at reset and keeps it for the episode, and
steps that object's physics; on MJX only objects of one model structure share a batch (a clear error otherwise), which
the one-structure template gives every procedural category (``scene.build_scene(..., slots=n)``)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.assets import procedural
from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.scene import TEMPLATE_SLOTS, SceneConfig, build_scene
from dragmesh2_jax.task.config import AramConfig, Constraint, RewardConfig
from dragmesh2_jax.task.env import PullTask, make_batched
from dragmesh2_jax.task.mix import CURRICULUM_PRIOR, CURRICULUM_RATE, OBJECT_END, ObjectMix
from dragmesh2_jax.task.wrappers import AutoReset
from tests.conftest import require_warp

DRAWER, DOOR = (str(packaged_object(n)) for n in ("drawer_cabinet_0000", "door_cabinet_0000"))


def test_a_batch_mixes_a_drawer_and_a_door_on_the_c_engine():
    tasks = [load_task(o, None, backend="mujoco") for o in (DRAWER, DOOR)]
    mix = ObjectMix(tasks)
    assert tasks[0].scene.model.ngeom != tasks[1].scene.model.ngeom  # other meshes: the geom fields are padded
    reset, step = make_batched(AutoReset(mix))
    s = jax.jit(reset)(jax.random.split(jax.random.PRNGKey(3), 12), jnp.ones(12))
    objects = np.asarray(s.info["object"])
    assert set(objects) == {0, 1}
    # each world starts at its own object's expert grasp: the handle it observes is that object's
    first = [(t.data.physics, jax.tree.map(lambda x: x[0], t.data.physics.bank)) for t in tasks]
    handles = np.stack([np.asarray(t.backend.kinematics(*d).handle_pos) for t, d in zip(tasks, first, strict=True)])
    np.testing.assert_allclose(np.asarray(s.obs.state[:, 102:105]), handles[objects], atol=1e-5)
    run = jax.jit(lambda s: jax.lax.scan(lambda s, _: (step(s, jnp.zeros((12, 51))), None), s, None, length=20)[0])
    s = run(s)
    assert np.isfinite(np.asarray(s.obs.state)).all() and float(s.metrics["nonfinite"].sum()) == 0
    # a revolute door and a prismatic drawer: each world's target joint moved its own way (the door in radians)
    q = np.asarray(s.metrics["q"])
    assert np.all(q[objects == 1] >= tasks[1].traj.q_min - 1e-3) and np.all(q[objects == 0] >= -1e-3)


def test_under_the_expert_prior_each_world_replays_its_own_objects_drag():
    """A residual over a mix (the residual generalist): a zero action follows the drag of the object the world drew,
    so every world opens its own drawer or door to success."""
    tasks = [load_task(o, None, backend="mujoco", expert_prior=True) for o in (DRAWER, DOOR)]
    reset, step = make_batched(AutoReset(ObjectMix(tasks)))
    s = jax.jit(reset)(jax.random.split(jax.random.PRNGKey(3), 8), jnp.ones(8))
    objects = np.asarray(s.info["object"])
    run = jax.jit(lambda s: jax.lax.scan(lambda s, _: (step(s, jnp.zeros((8, 51))), s.metrics["q"]), s, None,
                                         length=200)[1])
    q = np.asarray(run(s))
    assert set(objects) == {0, 1}
    for k, t in enumerate(tasks):
        assert np.all(q[:, objects == k].max(0) >= float(t.params.q_done) - 1e-4)  # success


def test_on_mjx_objects_of_their_own_structures_do_not_share_a_batch():
    """MJX stacks the models: one object at two nominal dampings mixes; a drawer and a door each in its own structure
    (other meshes) is one error line, nothing compiled (a mix of them is built on the template: below)."""
    base = load_task(DRAWER, None, backend="mjx")
    same = [PullTask(build_scene(base.scene.obj, SceneConfig(damping=d)), base.traj, base.config) for d in (10.0, 30.0)]
    mix = ObjectMix(same)
    assert mix.data.physics.model.dof_damping.shape[0] == 2
    with pytest.raises(DragMeshError, match="cannot share one batch on this engine"):
        ObjectMix([same[0], load_task(DOOR, None, backend="mjx")])


@pytest.fixture(scope="module")
def dishwasher(tmp_path_factory) -> str:
    return str(procedural.synthesize("dishwasher", 1, procedural.GENERALIST_SEED, tmp_path_factory.mktemp("mix"))[0])


def _template_mix(dishwasher: str, backend: str, impl: str = "jax") -> ObjectMix:
    """The packaged drawer and door and a procedural dishwasher (a slide, a side hinge, a bottom hinge) on the
    one-structure template, each world's applied action its object's expert drag (``expert_prior``, zero action)."""
    return ObjectMix([load_task(o, None, backend=backend, impl=impl, slots=TEMPLATE_SLOTS, expert_prior=True)
                      for o in (DRAWER, DOOR, dishwasher)])


def _verdicts(mix: ObjectMix, worlds: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Each world's object and whether its episode opened the part (x1, the exact expert grasp)."""
    reset, step = make_batched(mix.sized(worlds))
    length = mix.config.episode_length
    s = jax.jit(reset)(jax.random.split(jax.random.PRNGKey(3), worlds), jnp.ones(worlds))
    run = jax.jit(lambda s: jax.lax.scan(lambda s, _: (step(s, jnp.zeros((worlds, 51))), s.metrics["success"]), s,
                                         None, length=length)[1])
    return np.asarray(s.info["object"]), np.asarray(run(s)).any(0)


@pytest.fixture(scope="module")
def c_engine_verdicts(dishwasher):
    return _verdicts(_template_mix(dishwasher, "mujoco"))


@pytest.mark.parametrize("impl", ["jax", pytest.param("warp", marks=[pytest.mark.xdist_group("warp"),
                                                                     pytest.mark.long])])
@pytest.mark.mjx
def test_a_template_mix_of_three_categories_steps_on_mjx_with_the_c_engine_s_verdicts(impl, dishwasher,
                                                                                      c_engine_verdicts):
    """One compiled program over a batch that mixes a drawer, a door and a dishwasher: every world opens its own
    part, as on the C engine (whose template opens each part as the object's own scene does:
    tests/test_scene_template.py)."""
    if impl == "warp":
        require_warp()
    objects, opened = c_engine_verdicts
    assert set(objects) == {0, 1, 2} and opened.all()
    mix = _template_mix(dishwasher, "mjx", impl)
    assert mix.data.physics.model.jnt_axis.shape[0] == 3  # one model per object, stacked
    # one budget for every object (``ContactBudget.joined``: the most any of them needs), the overflow check's too
    assert all(t.budget == mix.budget for t in mix.tasks) and mix.base.budget == mix.budget
    mjx_objects, mjx_opened = _verdicts(mix)
    np.testing.assert_array_equal(mjx_objects, objects)  # the same draw of objects ...
    np.testing.assert_array_equal(mjx_opened, opened)  # ... each opened as on the C engine


def test_objects_of_another_task_config_do_not_mix():
    with pytest.raises(DragMeshError, match="task config"):
        ObjectMix([load_task(DRAWER, None, backend="mujoco"), load_task(DOOR, None, backend="mujoco", alpha=0.03)])


def test_a_mix_binds_the_reward_s_adaptive_weights_for_every_object():
    """One set of ARAM and constraint weights, seen by every object's reward (the trainer's hook)."""
    reward = RewardConfig(aram=AramConfig(), constraints=(Constraint(measure="load"),))
    mix = ObjectMix([load_task(o, None, backend="mujoco", reward=reward) for o in (DRAWER, DOOR)])
    weights = {"aram_lambda": jnp.float32(0.5), "multipliers": jnp.asarray([2.0], jnp.float32)}
    bound = mix.bind(mix.bind_weights(mix.data, weights))
    for i in range(mix.num_objects):
        p = bound.task(i).params
        assert float(p.aram_lambda) == 0.5 and p.multipliers.tolist() == [2.0]
    assert {k: v.shape for k, v in mix.adaptive_weights().items()} == {"aram_lambda": (), "multipliers": (1,)}


def test_the_object_curriculum_draws_the_objects_the_policy_fails():
    """Each object's success rate moves by the episodes that ended on it; the draw leans towards the failed one by
    the curriculum's share; without the curriculum there are no rates and no per-step object metric."""
    mix = ObjectMix([load_task(o, None, backend="mujoco", object_curriculum=1.0) for o in (DRAWER, DOOR)])
    weights = mix.adaptive_weights()
    assert weights["object_success"].tolist() == [CURRICULUM_PRIOR] * 2
    # two steps of three worlds: the drawer's two episodes succeed, the door's two fail, one world goes on
    steps = {OBJECT_END: jnp.asarray([[0.0, 1.0, -1.0], [0.0, -1.0, 1.0]]),
             "success": jnp.asarray([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])}
    moved, metrics = mix.update_weights(weights, {"success": 0.5, "episodes": 4.0, "clip099": 0.0}, steps)
    np.testing.assert_allclose(moved["object_success"], [CURRICULUM_PRIOR + CURRICULUM_RATE * (1 - CURRICULUM_PRIOR),
                                                         CURRICULUM_PRIOR - CURRICULUM_RATE * CURRICULUM_PRIOR])
    assert float(metrics["draw_peak"]) > 1.0  # no longer uniform
    # a policy that always opens the drawer and never the door: nearly every reset draws the door
    bound = mix.bind(mix.bind_weights(mix.data, {**weights, "object_success": jnp.asarray([1.0, 0.0])}))
    p = np.asarray(bound.data.params.draw_weight)
    assert p.sum() == pytest.approx(1.0) and p[1] > 0.9
    objects = np.asarray(jax.jit(jax.vmap(lambda k: bound.reset(k).info["object"]))(
        jax.random.split(jax.random.PRNGKey(0), 200)))
    assert 0.85 < objects.mean() < 1.0  # the door, as drawn
    half = ObjectMix([load_task(o, None, backend="mujoco", object_curriculum=0.5) for o in (DRAWER, DOOR)])
    assert float(half.draw(jnp.asarray([1.0, 0.0]))[0]) > 0.25  # half the draws stay uniform
    plain = ObjectMix([load_task(o, None, backend="mujoco") for o in (DRAWER, DOOR)])
    assert "object_success" not in plain.adaptive_weights()
    assert OBJECT_END not in jax.jit(plain.reset)(jax.random.PRNGKey(0)).metrics
