"""The hand + object scene: structure, contact filtering, placement. That every real scene compiles to MJX and
steps it finite is shown by a whole tracking episode per object on both backends (tests/task/test_tracking.py)."""

import mujoco
import numpy as np
import pytest

from dragmesh2_jax.scene import SceneConfig, build_scene
from tests.conftest import REAL_OBJECTS


@pytest.mark.parametrize("oid", REAL_OBJECTS)
def test_scene_structure(real_scenes, oid):
    sc = real_scenes[oid]
    m, ids = sc.model, sc.ids
    assert m.nu == 51 and len(ids.hand_actuators) == 51
    assert m.nv == 52  # 51 hand DoFs + the target joint; other object joints are locked
    # the target joint is passive: no actuator drives it, and it carries the nominal damping
    assert m.dof_jntid[ids.target_dof] not in set(m.actuator_trnid[:, 0])
    assert m.dof_damping[ids.target_dof] == pytest.approx(10.0)
    assert ids.target_range[1] > ids.target_range[0]
    # hand geoms never collide with each other; object geoms never with each other
    hand, obj = ids.hand_geoms, ids.object_collision_geoms
    assert len(hand) == 16 and len(obj) >= 1
    ct, ca = m.geom_contype, m.geom_conaffinity
    assert not (ct[hand[0]] & ca[hand[1]]) and not (ct[obj[0]] & ca[obj[-1]])
    assert (ct[hand[0]] & ca[obj[0]]) or (ct[obj[0]] & ca[hand[0]])


@pytest.mark.parametrize("oid", REAL_OBJECTS)
def test_handle_site_is_at_the_scaled_annotated_handle(real_scenes, oid):
    sc = real_scenes[oid]
    d = sc.initial_data()
    expected = np.asarray(sc.config.object_pos) + sc.config.scale * sc.obj.target.handle.centre
    np.testing.assert_allclose(d.site_xpos[sc.ids.handle_site], expected, atol=1e-9)
    # site axes: x = long axis, y = outward normal
    np.testing.assert_allclose(d.site_xmat[sc.ids.handle_site].reshape(3, 3)[:, 1], sc.handle.normal, atol=1e-9)


def test_target_joint_moves_the_handle_and_prismatic_limits_scale(real_scenes):
    sc = real_scenes["45261"]
    assert sc.ids.target_range[1] == pytest.approx(0.4 * 0.87)
    d = sc.initial_data()
    before = d.site_xpos[sc.ids.handle_site].copy()
    d.qpos[sc.ids.target_qpos] = 0.1
    mujoco.mj_forward(sc.model, d)
    np.testing.assert_allclose(d.site_xpos[sc.ids.handle_site] - before, [-0.1, 0, 0], atol=1e-9)


def test_passive_object_stays_closed_without_contact(real_scenes):
    sc = real_scenes["45780"]
    d = sc.initial_data()
    for _ in range(240):
        mujoco.mj_step(sc.model, d)
    assert abs(d.qpos[sc.ids.target_qpos]) < 1e-6 and np.isfinite(d.qpos).all()


def test_bad_scene_config():
    from dragmesh2_jax.errors import DragMeshError

    with pytest.raises(DragMeshError, match="scale"):
        SceneConfig(scale=0)
    with pytest.raises(DragMeshError, match="collide"):
        SceneConfig(collide="everything")


def test_collide_all_adds_static_pieces(real_objects, real_scenes):
    sc_all = build_scene(real_objects["45780"], SceneConfig(collide="all"))
    assert len(sc_all.ids.object_collision_geoms) > len(real_scenes["45780"].ids.object_collision_geoms)


def _urdf_edit(folder, old: str, new: str) -> None:
    path = folder / "mobility_annotation_gapartnet.urdf"
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))


def test_a_knob_on_a_joint_of_its_own_moves_with_the_door_and_a_handle_without_a_mesh_is_its_annotated_box(
        tmp_path):
    """Two ways a real door's knob is modelled: a link on a joint of its own (the knob's turn) is welded to the
    door it opens (before, its pieces stood still in the world while the door swung), and a handle link without a
    mesh is grasped by its annotated box (``stats`` says which); the object as synthesised collides by its meshes."""
    from dragmesh2_jax.assets.gapartnet import load_gapartnet
    from dragmesh2_jax.assets.procedural import synthesize

    def target_geoms(scene):
        m = scene.model
        body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "object_target")
        return {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) for g in range(m.ngeom)
                if m.geom_bodyid[g] == body and g in scene.ids.object_collision_geoms}

    (turning,) = synthesize("double_knob_door", 1, 0, tmp_path / "turning")
    assert build_scene(load_gapartnet(turning)).stats["handle_geometry"] == "mesh"
    _urdf_edit(turning, '<joint name="joint_handle" type="fixed">', '<joint name="joint_handle" type="revolute">'
               '<axis xyz="0 0 1"/><limit lower="0.0" upper="1.0"/>')
    scene = build_scene(load_gapartnet(turning))
    assert scene.obj.target.joint.name == "joint_door" and scene.stats["handle_geometry"] == "mesh"
    assert {g for g in target_geoms(scene) if g.startswith("link_handle_")}  # the knob swings with the door

    (bare,) = synthesize("double_knob_door", 1, 0, tmp_path / "bare")
    path = bare / "mobility_annotation_gapartnet.urdf"
    text = path.read_text()
    start = text.index('<link name="link_handle">')
    path.write_text(text[:start] + '<link name="link_handle">' + text[text.index("</link>", start):])
    scene = build_scene(load_gapartnet(bare))
    assert scene.stats["handle_geometry"] == "annotated box" and "handle_box" in target_geoms(scene)
    m, d = scene.model, mujoco.MjData(scene.model)
    mujoco.mj_forward(m, d)
    box = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "handle_box")
    np.testing.assert_allclose(d.geom_xpos[box], scene.handle.centre, atol=1e-6)  # where the handle frame is
