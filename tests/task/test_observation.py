"""The state vectors: the paper's unchanged by default, the transferable one invariant to where the object stands."""

import dataclasses

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.hand import NUM_VIRTUAL
from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.runs.session import start_or_resume
from dragmesh2_jax.scene import build_scene
from dragmesh2_jax.task.config import TaskConfig
from dragmesh2_jax.task.env import PullTask
from dragmesh2_jax.task.observation import STATE_SIZE, handle_state, joint_geometry, state_size
from dragmesh2_jax.task.protocol import observation_spec
from tests.conftest import tiny_spec

SHIFT = np.array([0.3, -0.2, 0.1])  # m


def _handle_task(base: PullTask, scene=None, shift=np.zeros(3), observation: str = "handle") -> PullTask:
    """``base``'s object (or ``scene``'s) with ``observation``, from the expert grasp moved by ``shift``."""
    frame = base.traj.frames[base.traj.drag_start]
    hand_q = np.asarray(frame.hand_q, np.float64).copy()
    hand_q[:3] += shift
    start = hand_q, frame.joint_positions[base.traj.target_index]
    return PullTask(scene or base.scene, base.traj, dataclasses.replace(base.config, observation=observation), start)


def test_sizes_come_from_the_config(drawer_task):
    assert state_size(drawer_task.config) == STATE_SIZE == 120
    assert state_size(TaskConfig(observation="handle")) == 110
    assert state_size(TaskConfig(observation="handle", force_obs=True)) == 132
    assert observation_spec(_handle_task(drawer_task)).state.shape == (110,)
    with pytest.raises(DragMeshError, match="unknown observation 'world'"):
        TaskConfig(observation="world")


def test_handle_state_is_finite_and_holds_the_part_in_task_units(drawer_task):
    task = _handle_task(drawer_task)
    s = task.reset(jax.random.PRNGKey(0))
    s = task.step(s, jnp.zeros(51).at[:3].set(jnp.asarray(task.scene.handle.normal)))
    x = np.asarray(s.obs.state)
    assert x.shape == (110,) and x.dtype == np.float32 and np.all(np.isfinite(x))
    k, p = task.kinematics(s), task.params
    delta = float(p.q_goal - p.q_start)
    np.testing.assert_allclose(x[-3:], [float(task.progress(k.obj_q)), float(p.q_done - k.obj_q) / delta,
                                        float(k.obj_qd) / delta], rtol=1e-5, atol=1e-6)
    # a drawer: its slide runs along the handle's normal, no hinge radius
    np.testing.assert_allclose(np.abs(x[-8:-5]), [0.0, 1.0, 0.0], atol=1e-5)
    assert x[-5] == 0.0 and x[-4] == 0.0
    np.testing.assert_allclose(x[:90], np.concatenate([k.hand_q[NUM_VIRTUAL:], k.hand_qd[NUM_VIRTUAL:]]), atol=1e-6)


def test_handle_state_is_invariant_to_moving_the_object(drawer_task):
    """The same object and grasp at another place: the paper's s_t changes, the handle one does not."""
    moved_scene = build_scene(drawer_task.scene.obj, dataclasses.replace(
        drawer_task.scene.config, object_pos=tuple(np.add(drawer_task.scene.config.object_pos, SHIFT))))
    for observation in ("handle", "paper"):
        here, there = (_handle_task(drawer_task, scene, shift, observation)
                       for scene, shift in ((None, np.zeros(3)), (moved_scene, SHIFT)))
        a, b = (np.asarray(t.reset(jax.random.PRNGKey(0)).obs.state) for t in (here, there))
        if observation == "handle":
            np.testing.assert_allclose(a, b, atol=2e-4)
        else:
            np.testing.assert_allclose(a[:3] + SHIFT, b[:3], atol=1e-4)  # the wrist moved with the object
            assert np.abs(a - b).max() > 0.05


def test_a_hinge_keeps_its_axis_and_radius_in_the_handle_frame():
    """A door: the hinge axis read in the handle's frame and the handle's distance from it, open as closed."""
    scene = build_scene(load_gapartnet(packaged_object("door_cabinet_0000")))
    axis, radius, sign = joint_geometry(scene)
    assert scene.ids.target_is_revolute and 0.05 < radius < 1.0 and sign == 1.0  # its bar points down already
    np.testing.assert_allclose(np.linalg.norm(axis), 1.0, rtol=1e-6)
    m, d = scene.model, mujoco.MjData(scene.model)
    d.qpos[scene.ids.target_qpos] = np.mean(scene.ids.target_range)
    mujoco.mj_kinematics(m, d)
    joint, site = m.dof_jntid[scene.ids.target_dof], scene.ids.handle_site
    arm = d.site_xpos[site] - d.xanchor[joint]
    np.testing.assert_allclose(d.site_xmat[site].reshape(3, 3).T @ d.xaxis[joint], axis, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(arm - (arm @ d.xaxis[joint]) * d.xaxis[joint]), radius, rtol=1e-6)


def test_a_bar_given_the_other_way_reads_the_same():
    """An importer may point a bar's long axis up or down (GAPartNet's doors up, the procedural ones down): the same
    door with its handle frame turned half a turn about the normal gives the same handle observation."""
    task = load_task(str(packaged_object("door_cabinet_0000")), None, backend="mujoco", observation="handle")
    scene = build_scene(task.scene.obj, task.scene.config)
    site = scene.ids.handle_site
    half_turn = Rotation.from_euler("y", np.pi)  # about the site's own y: its outward normal
    quat = (Rotation.from_quat(scene.model.site_quat[site], scalar_first=True) * half_turn).as_quat(scalar_first=True)
    scene.model.site_quat[site] = quat
    (axis, radius, sign), (axis2, radius2, sign2) = joint_geometry(task.scene), joint_geometry(scene)
    assert sign == -sign2 and radius == pytest.approx(radius2)
    np.testing.assert_allclose(axis, axis2, atol=1e-6)
    k = task.kinematics(task.reset(jax.random.PRNGKey(0)))
    other = k.replace(handle_rot=jnp.concatenate([-k.handle_rot[:3], k.handle_rot[3:]]))
    np.testing.assert_allclose(handle_state(k, task.params), handle_state(other, task.params.replace(
        joint_axis=jnp.asarray(axis2, jnp.float32), long_sign=jnp.float32(sign2))), atol=1e-6)


def _turned(k, q_rot: np.ndarray, t: np.ndarray):
    """``k`` with the whole scene turned by ``q_rot`` and moved by ``t`` (the wrist's Euler angles and rates
    re-derived, as the hand's virtual joints would read)."""
    hq, hqd = np.asarray(k.hand_q, np.float64).copy(), np.asarray(k.hand_qd, np.float64).copy()
    R = Rotation.from_euler("XYZ", hq[3:6]).as_matrix()
    rx = Rotation.from_euler("X", hq[3]).as_matrix()
    E = np.stack([np.eye(3)[0], rx[:, 1], (rx @ Rotation.from_euler("Y", hq[4]).as_matrix())[:, 2]], axis=1)
    omega = E @ hqd[3:6]
    new = Rotation.from_matrix(q_rot @ R).as_euler("XYZ")
    rx2 = Rotation.from_euler("X", new[0]).as_matrix()
    E2 = np.stack([np.eye(3)[0], rx2[:, 1], (rx2 @ Rotation.from_euler("Y", new[1]).as_matrix())[:, 2]], axis=1)
    hq[:3], hq[3:6] = q_rot @ hq[:3] + t, new
    hqd[:3] = q_rot @ hqd[:3]
    hqd[3:6] = np.linalg.solve(E2, q_rot @ omega)
    rot = np.asarray(k.handle_rot, np.float64)
    f32 = lambda x: jnp.asarray(x, jnp.float32)  # noqa: E731
    return k.replace(hand_q=f32(hq), hand_qd=f32(hqd), palm=f32(q_rot @ np.asarray(k.palm) + t),
                     handle_pos=f32(q_rot @ np.asarray(k.handle_pos) + t),
                     handle_rot=f32(np.concatenate([q_rot @ rot[:3], q_rot @ rot[3:]])))


def test_handle_state_is_invariant_to_turning_the_scene(drawer_task):
    """A rigid motion of everything (object, hand, their velocities) leaves the handle state as it was: the wrist's
    rotation and the palm's velocity are read in the handle's frame."""
    task = _handle_task(drawer_task)
    k = task.kinematics(task.reset(jax.random.PRNGKey(0)))
    rng = np.random.default_rng(0)
    k = k.replace(hand_qd=k.hand_qd.at[:NUM_VIRTUAL].set(jnp.asarray(rng.normal(size=NUM_VIRTUAL), jnp.float32)))
    q_rot = Rotation.from_euler("xyz", [0.3, -0.5, 1.2]).as_matrix()
    a = np.asarray(handle_state(k, task.params))
    b = np.asarray(handle_state(_turned(k, q_rot, SHIFT), task.params))
    np.testing.assert_allclose(a, b, atol=1e-4)


def test_hold_blind_handle_trains_and_records_its_observation(tmp_path):
    spec = tiny_spec("hold_blind_handle", schedule={"epochs": 1, "robust_every": 0})
    run = RunDir(tmp_path / "run")
    start_or_resume(spec, [run], resume=False, progress=False)
    assert run.record()["task"]["observation"] == "handle"
