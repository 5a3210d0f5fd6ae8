"""The rested grasp: a grasp planned on MuJoCo's soft contacts, which the drives press millimetres into the handle on
the hand's stiff ones, comes to rest on the handle's surface under light finger drives, keeps hold of it, and its drag
is planned again from there (``trajectory.rest``, ``TaskConfig.expert_rest``)."""

import mujoco
import numpy as np
import pytest

from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.scene import SceneConfig, contact_depth
from dragmesh2_jax.task.expert import expert_replay
from dragmesh2_jax.trajectory import grasp, rest
from dragmesh2_jax.trajectory.generator import handle_grip

#: The deepest the hand may be in the handle at rest (m): the hand's contacts give about 1 mm under light drives.
RESTED_DEPTH = 0.001
#: The issue's bound on the whole drag (m).
MAX_DEPTH = 0.002
SOFT_PLAN = {"expert_plan_contact": "mujoco"}


@pytest.fixture(scope="module")
def tasks():
    """The packaged drawer on the hand's contacts with its grasp planned on MuJoCo's soft ones, as generated and
    rested."""
    drawer, scene = str(packaged_object("drawer_cabinet_0000")), SceneConfig(object_contact="hand")
    return (load_task(drawer, None, backend="mujoco", scene_config=scene, **SOFT_PLAN),
            load_task(drawer, None, backend="mujoco", scene_config=scene, expert_rest=True, **SOFT_PLAN))


def _depth_and_grip(task, hand_q):
    scene = task.scene
    d = mujoco.MjData(scene.model)
    d.qpos[scene.ids.hand_qpos], d.qpos[scene.ids.target_qpos] = hand_q, task.traj.q_start
    mujoco.mj_forward(scene.model, d)
    return contact_depth(scene.geom_mask(scene.ids.hand_geoms), d), handle_grip(scene, d, 0.0005)[0]


def test_a_soft_planned_grasp_lies_inside_the_handle_and_rests_on_its_surface_still_touching_it(tasks):
    planned, rested = tasks
    frame = planned.traj.frames[planned.traj.drag_start]
    deep, _ = _depth_and_grip(planned, frame.hand_q)
    assert deep > 2 * MAX_DEPTH  # the soft contacts let the drives press it in
    q = rest.rest(planned.scene, frame.hand_q, planned.traj.q_start)
    depth, touching = _depth_and_grip(planned, q)
    assert depth <= RESTED_DEPTH and touching >= 3, (depth, touching)
    np.testing.assert_allclose(rested.traj.frames[rested.traj.drag_start].hand_q, q)


def test_the_rested_drag_starts_at_the_rest_and_grips_just_past_it(tasks):
    planned, rested = tasks
    s = rested.traj.drag_start
    before, after = planned.traj.frames, rested.traj.frames
    grip = grasp.gripping(np.asarray(after[s].finger_dofs), rested.config.grip_closure)
    np.testing.assert_allclose(rested.traj.header["grip"], grip)
    np.testing.assert_allclose(rested.traj.start_hand_q[6:], grip)
    shift = np.asarray(after[s].virtual_xyz) - np.asarray(before[s].hand_target[:3])
    assert np.linalg.norm(shift) > 0.002  # the planned wrist lies inside the handle: the drag starts where it rests
    for k in range(s, len(after)):  # a drawer's drag does not turn the hand: the same shift at every frame
        np.testing.assert_allclose(np.subtract(after[k].hand_target[:3], before[k].hand_target[:3]), shift, atol=1e-9)
        if after[k].phase == "drag":
            np.testing.assert_allclose(after[k].hand_target[6:], grip)
    assert all(a == b for a, b in zip(after[:s], before[:s], strict=True))
    assert rested.traj.header["generator"]["rested"]["force_nm"] == rest.REST_FORCE


@pytest.mark.parametrize("damping", [1.0, 8.0])
def test_the_rested_expert_opens_the_drawer_with_its_fingers_on_the_bar_where_the_soft_plan_presses_into_it(
        tasks, damping):
    planned, rested = tasks
    before, after = (expert_replay(t.scene, t.traj, t.config, t.substeps, damping) for t in tasks)
    assert after.steps is not None and after.deepest <= MAX_DEPTH, after
    assert before.deepest > after.deepest, (before, after)
