"""Where a task's trajectory is generated: in its own scene, or planned where MuJoCo's soft contacts seat the hand."""

import dataclasses

from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.runs.build import task_of
from dragmesh2_jax.runs.spec import method_defaults
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.task.expert import expert_replay
from dragmesh2_jax.task.load import plan_scene_config

DRAWER = str(packaged_object("drawer_cabinet_0000"))


def _task(method: str):
    tree = method_defaults(method)
    return task_of(DRAWER, None, dataclasses.replace(tree.task, backend="mujoco"), tree.scene)


def test_a_seat_planned_on_soft_contacts_is_the_recipes_drag_held_on_the_hands_contacts_with_less_sinking():
    """The recipe's expert drag (planned on MuJoCo's default contacts) run on the firm grip's physics: the same
    frames, the hand's contacts in the task's scene, and replayed at x1 and x8 from the exact grasp it opens the
    drawer sinking less than on the contacts it was planned on."""
    recipe, seat = _task("hold_blind_residual_seated"), _task("hold_blind_residual_seat")
    assert seat.traj.frames == recipe.traj.frames
    assert seat.scene.config.object_contact == "hand" and recipe.scene.config.object_contact == "mujoco"
    assert plan_scene_config(seat.config, seat.scene.config) == SceneConfig()
    for d in (1.0, 8.0):
        soft, firm = (expert_replay(t.scene, t.traj, t.config, t.substeps, d) for t in (recipe, seat))
        assert soft.steps is not None and firm.steps is not None
        assert firm.deepest < 0.75 * soft.deepest
