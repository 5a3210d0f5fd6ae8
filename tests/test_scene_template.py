"""The one-structure template (``scene.build_scene(..., slots=n)``): every procedural category in the same bodies,
joints, geoms and names, so that MJX stacks a mix of categories; the object's own geometry, joint and mass as data,
its physics that of its own scene (the parked joint moves nothing, the empty slots meet nothing)."""

import mujoco
import numpy as np
import pytest

from dragmesh2_jax.assets import procedural
from dragmesh2_jax.assets.collision import ConvexPiece, as_box
from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.evaluate import track
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.scene import PARKED_POS, SLOT, TEMPLATE_JOINTS, TEMPLATE_SLOTS, SceneConfig, build_scene
from tests.conftest import REAL_OBJECTS

#: Model fields that fix a model's structure for MJX (sizes, types, addresses, names): equal in every template world.
STRUCTURE = ("nq", "nv", "nbody", "njnt", "ngeom", "nmesh", "nsite", "nsensor", "nu", "jnt_type", "jnt_qposadr",
             "jnt_bodyid", "geom_type", "geom_bodyid", "geom_contype", "geom_conaffinity", "geom_dataid", "names")


@pytest.fixture(scope="module")
def mix_objects(tmp_path_factory):
    """Every object of the generalist's mix (its 10 categories, 40 objects): its coverage is the template's."""
    out = tmp_path_factory.mktemp("template")
    return [load_gapartnet(p) for p in procedural.synthesize_mix(procedural.GENERALIST_MIX, procedural.GENERALIST_SEED,
                                                                 out)]


def _structure(model: mujoco.MjModel) -> tuple:
    return tuple(np.asarray(getattr(model, f)).tobytes() for f in STRUCTURE)


def test_every_object_of_the_mix_builds_on_one_structure_with_its_own_geometry_joint_and_mass(mix_objects):
    own = [build_scene(o) for o in mix_objects]
    template = [build_scene(o, slots=TEMPLATE_SLOTS) for o in mix_objects]
    assert len({_structure(s.model) for s in own}) > 1  # their own scenes differ ...
    assert len({_structure(s.model) for s in template}) == 1  # ... the template is one structure
    kinds = set()
    for o, t in zip(own, template, strict=True):
        m, ids = t.model, t.ids
        moving = m.dof_jntid[ids.target_dof]
        kinds.add(int(m.jnt_type[moving]))
        assert t.ids.target_is_revolute == o.ids.target_is_revolute and t.ids.target_range == o.ids.target_range
        parked = [m.joint(n).id for n in TEMPLATE_JOINTS if m.joint(n).id != moving]
        assert np.all(m.jnt_axis[parked] == 0)  # the other kind of joint moves nothing
        np.testing.assert_allclose(m.jnt_axis[moving], o.model.jnt_axis[o.model.dof_jntid[o.ids.target_dof]])
        # the part's mass and its contacts' inverse weights are its own scene's (the parked joint adds no mobility)
        tb, ob = m.body("object_target").id, o.model.body("object_target").id
        np.testing.assert_allclose(m.body_mass[tb], o.model.body_mass[ob])
        np.testing.assert_allclose(m.body_invweight0[tb], o.model.body_invweight0[ob], rtol=1e-6)
        # the colliding pieces are the same boxes in the same places; the slots left over sit far out of reach
        d_own, d_tpl = mujoco.MjData(o.model), mujoco.MjData(m)
        mujoco.mj_forward(o.model, d_own)
        mujoco.mj_forward(m, d_tpl)
        used = [g for g in ids.object_collision_geoms if not np.allclose(m.geom_pos[g], PARKED_POS)]
        own_centres, centres = d_own.geom_xpos[o.ids.object_collision_geoms], d_tpl.geom_xpos[used]
        apart = np.linalg.norm(centres[:, None] - own_centres[None], axis=-1)
        assert len(centres) == len(own_centres) and apart.min(0).max() < 1e-5 and apart.min(1).max() < 1e-5
        assert len(ids.object_collision_geoms) == TEMPLATE_SLOTS
        assert np.all(m.geom_type[used] == mujoco.mjtGeom.mjGEOM_BOX)
    assert kinds == {mujoco.mjtJoint.mjJNT_SLIDE, mujoco.mjtJoint.mjJNT_HINGE}


def test_the_template_refuses_what_it_cannot_hold(mix_objects, real_objects):
    drawer = next(o for o in mix_objects if o.object_id.startswith("drawer_cabinet"))
    with pytest.raises(DragMeshError, match="do not fit the template's 3 slots"):
        build_scene(drawer, slots=3)
    with pytest.raises(DragMeshError, match="collide='target'"):
        build_scene(drawer, SceneConfig(collide="all"), slots=TEMPLATE_SLOTS)
    with pytest.raises(DragMeshError, match="not a box"):  # a real object's hulls
        build_scene(real_objects[REAL_OBJECTS[0]], slots=TEMPLATE_SLOTS)


def test_a_box_hull_is_its_box_and_another_hull_is_none():
    box = ConvexPiece(np.zeros((0, 3)), np.array([0.1, 0.2, 0.3]), np.eye(3), np.array([0.05, 0.01, 0.2]))
    fitted = as_box(ConvexPiece(box.corners()[::-1]))
    np.testing.assert_allclose(fitted.corners()[np.lexsort(fitted.corners().T)],
                               box.corners()[np.lexsort(box.corners().T)], atol=1e-9)
    cube = ConvexPiece(np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float))
    np.testing.assert_allclose(as_box(cube).box_half, 0.5)  # no principal axes: taken axis-aligned
    assert as_box(ConvexPiece(np.vstack([cube.vertices[:7], [[0.5, 0.5, 1.5]]]))) is None


@pytest.mark.parametrize("name", ["drawer_cabinet_0000", "door_cabinet_0000"])
def test_on_the_c_engine_the_template_tracks_as_the_object_s_own_scene(name):
    """The expert drag's verdict and how far it opens the part, the packaged drawer and door at x1 and x4."""
    folder = str(procedural.packaged_object(name))
    own = load_task(folder, None, backend="mujoco")
    template = load_task(folder, own.traj, backend="mujoco", slots=TEMPLATE_SLOTS)
    for a, b in zip(track(own, [1.0, 4.0]), track(template, [1.0, 4.0]), strict=True):
        assert a["success_rate"] == b["success_rate"] == 1.0
        assert abs(a["progress_mean"] - b["progress_mean"]) < 0.02
        assert abs(a["wrist_load_peak_n"] - b["wrist_load_peak_n"]) <= 0.15 * a["wrist_load_peak_n"] + 2.0
    assert SLOT + "0" in {template.scene.model.geom(g).name for g in range(template.scene.model.ngeom)}
