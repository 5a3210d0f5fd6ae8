"""Where a task's trajectory is generated: in its own scene, planned where MuJoCo's soft contacts seat the hand, or
in both, the one that holds the part kept."""

import dataclasses

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.runs.build import task_of
from dragmesh2_jax.runs.spec import method_defaults
from dragmesh2_jax.scene import SceneConfig, build_scene
from dragmesh2_jax.task import load
from dragmesh2_jax.task.config import TaskConfig
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


def test_a_plan_that_holds_keeps_the_runs_own_drag_unless_the_soft_seat_holds_the_part_harder(monkeypatch):
    """Under ``expert_plan_contact`` "holds" the drag is generated twice, in the run's scene (the hand's contacts) and
    in MuJoCo's soft one, and each replayed in the run's scene: the run's own is kept where it holds the part to as
    high a damping (a tie too), the soft one only where it holds to a higher one. Under "scene" it is generated once."""
    obj = load_gapartnet(DRAWER)
    scene = build_scene(obj, SceneConfig(object_contact="hand"))
    generated_in, held = [], {}

    def generate(obj, params, scene):
        generated_in.append(scene.config.object_contact)
        return scene.config.object_contact  # the scene a drag was planned in stands for the drag

    monkeypatch.setattr(load, "generate", generate)
    monkeypatch.setattr(load, "holds", lambda scene, traj, substeps, steps: held[traj])
    config = TaskConfig(expert_plan_contact="holds")
    for own, soft, kept in ((8.0, 8.0, "hand"), (4.0, 16.0, "mujoco"), (16.0, 4.0, "hand")):
        held.update(hand=own, mujoco=soft)
        generated_in.clear()
        assert load.generated(obj, scene, config) == kept
        assert sorted(generated_in) == ["hand", "mujoco"]
    generated_in.clear()
    assert load.generated(obj, scene, TaskConfig()) == "hand" and generated_in == ["hand"]
