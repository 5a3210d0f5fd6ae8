"""Several objects in one batch (task/mix.py): each world draws an object at reset and keeps it for the episode, and
steps that object's physics; on MJX only objects of one model structure can share a batch (a clear error otherwise)."""

import importlib.util

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.scene import SceneConfig, build_scene
from dragmesh2_jax.task.config import AramConfig, Constraint, RewardConfig
from dragmesh2_jax.task.env import PullTask, make_batched
from dragmesh2_jax.task.mix import CURRICULUM_PRIOR, CURRICULUM_RATE, OBJECT_END, ObjectMix
from dragmesh2_jax.task.wrappers import AutoReset

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
    handles = np.stack([np.asarray(t.kinematics(jax.tree.map(lambda x: x[0], t.data.physics.bank)).handle_pos)
                        for t in tasks])
    np.testing.assert_allclose(np.asarray(s.obs.state[:, 102:105]), handles[objects], atol=1e-5)
    run = jax.jit(lambda s: jax.lax.scan(lambda s, _: (step(s, jnp.zeros((12, 51))), None), s, None, length=20)[0])
    s = run(s)
    assert np.isfinite(np.asarray(s.obs.state)).all() and float(s.metrics["nonfinite"].sum()) == 0
    # a revolute door and a prismatic drawer: each world's target joint moved its own way (the door in radians)
    q = np.asarray(s.metrics["q"])
    assert np.all(q[objects == 1] >= tasks[1].traj.q_min - 1e-3) and np.all(q[objects == 0] >= -1e-3)


def test_on_mjx_only_objects_of_one_structure_share_a_batch():
    """MJX stacks the models: one object at two nominal dampings mixes; a drawer and a door (other meshes) is the
    documented limit, one error line (nothing compiles here)."""
    base = load_task(DRAWER, None, backend="mjx")
    same = [PullTask(build_scene(base.scene.obj, SceneConfig(damping=d)), base.traj, base.config) for d in (10.0, 30.0)]
    mix = ObjectMix(same)
    assert mix.data.physics.model.dof_damping.shape[0] == 2
    with pytest.raises(DragMeshError, match="cannot share one batch on this engine"):
        ObjectMix([same[0], load_task(DOOR, None, backend="mjx")])
    if importlib.util.find_spec("warp") is not None:
        warp = load_task(DRAWER, base.traj, backend="mjx", impl="warp")
        with pytest.raises(DragMeshError, match="MJX-Warp trains one object per run"):
            ObjectMix([warp, warp])


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
