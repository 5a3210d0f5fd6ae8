"""GAPartNet import on the real objects in ../shared: targets, joints, handles, frames; and bad input."""

import json
import shutil

import numpy as np
import pytest

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.scene import build_scene

# (target link, part category, joint type, handle link) per the paper's Appendix B selection rule
EXPECTED = {
    "45261": ("link_0", "slider_drawer", "prismatic", "link_6"),
    "45661": ("link_1", "slider_drawer", "prismatic", "link_5"),
    "45780": ("link_0", "hinge_door", "revolute", "link_3"),
    "11712": ("link_0", "hinge_door", "revolute", "link_3"),
}


@pytest.mark.parametrize("oid", list(EXPECTED))
def test_real_object_target_joint_and_handle(real_objects, oid):
    obj = real_objects[oid]
    link, cat, jtype, handle = EXPECTED[oid]
    s = obj.summary()
    assert s["target_part"] == {"link": link, "category": cat}
    assert s["target_joint"]["type"] == jtype
    assert s["handle"]["source"] == "handle" and s["handle"]["link"] == handle
    assert handle in obj.target.attached_links  # the handle is welded to the target part


@pytest.mark.parametrize("oid", list(EXPECTED))
def test_frames_are_z_up_with_outward_normals(real_objects, oid):
    obj = real_objects[oid]
    h, t = obj.target.handle, obj.target
    # PartNet-Mobility fronts face -x in the z-up base frame; the handle sticks out of the front
    np.testing.assert_allclose(h.normal, [-1, 0, 0], atol=1e-6)
    np.testing.assert_allclose(t.front_normal, [-1, 0, 0], atol=1e-6)
    for v in (h.long_axis, h.normal, h.short_axis):
        assert np.linalg.norm(v) == pytest.approx(1.0)
    assert abs(h.long_axis @ h.normal) < 1e-9
    assert h.length >= h.width and h.thickness > 0
    if t.joint.is_revolute:  # doors hinge about a vertical axis; +q swings the handle outwards
        assert abs(abs(t.joint.axis[2]) - 1) < 1e-6
        from dragmesh2_jax.assets.target import opening_direction

        assert opening_direction(t.part, t.joint, h.centre) @ h.normal > 0.5
    else:  # drawers slide out of the front
        np.testing.assert_allclose(t.joint.axis, [-1, 0, 0], atol=1e-6)


def test_reference_handle_decomposition_matches_the_facts(real_objects):
    """For GAPartNet handles our frame equals the reference's c0-c4 / c0-c1 / c0-c3 decomposition."""
    obj = real_objects["45261"]
    box = next(p.bbox for p in obj.parts if p.link == "link_6")
    h = obj.target.handle
    np.testing.assert_allclose(h.centre, box.mean(0))
    assert h.thickness == pytest.approx(np.linalg.norm(box[0] - box[4]))
    assert abs(h.long_axis @ (box[0] - box[1])) == pytest.approx(np.linalg.norm(box[0] - box[1]))


def test_revolute_joint_origin_is_on_the_hinge_edge(real_objects):
    obj = real_objects["45780"]
    j, part = obj.target.joint, obj.target.part
    lo, hi = part.bbox.min(0), part.bbox.max(0)
    # the hinge line lies on the door's box boundary (within 2 cm, unscaled)
    assert min(abs(j.origin[1] - lo[1]), abs(j.origin[1] - hi[1])) < 0.02


# ------------------------------------------------------------------------------------------- bad input


@pytest.fixture
def obj_copy(gapartnet_dir, tmp_path):
    dst = tmp_path / "45780"
    shutil.copytree(gapartnet_dir / "45780", dst)
    for p in dst.rglob("*"):
        p.chmod(0o644 if p.is_file() else 0o755)
    return dst


def _edit_urdf(folder, old, new, count=1):
    p = folder / "mobility_annotation_gapartnet.urdf"
    s = p.read_text()
    assert old in s
    p.write_text(s.replace(old, new, count))


@pytest.mark.parametrize("case, fragment", [
    ("missing_folder", "no such folder"),
    ("missing_urdf", "no URDF found"),
    ("malformed_xml", "malformed XML"),
    ("malformed_json", "malformed JSON"),
    ("missing_mesh", "references missing mesh"),
    ("no_movable_joint", "no movable"),
    ("unknown_joint_type", "unknown joint type"),
])
def test_bad_input_gives_one_line_error_naming_the_file(obj_copy, tmp_path, case, fragment):
    folder = obj_copy
    if case == "missing_folder":
        folder = tmp_path / "nope"
    elif case == "missing_urdf":
        (folder / "mobility_annotation_gapartnet.urdf").unlink()
        (folder / "mobility.urdf").unlink()
    elif case == "malformed_xml":
        _edit_urdf(folder, "</robot>", "</rob")
    elif case == "malformed_json":
        (folder / "link_annotation_gapartnet.json").write_text('[{"link_name": ')
    elif case == "missing_mesh":
        (folder / "textured_objs" / "original-45.obj").unlink()
    elif case == "no_movable_joint":
        _edit_urdf(folder, 'type="revolute"', 'type="fixed"', count=10)
    elif case == "unknown_joint_type":
        _edit_urdf(folder, 'type="revolute"', 'type="helical"')
    with pytest.raises(DragMeshError) as e:
        load_gapartnet(folder)
    msg = str(e.value)
    assert fragment in msg and "\n" not in msg
    assert str(folder) in msg or folder.name in msg


def test_cli_reports_bad_input_with_status_2_and_no_traceback(tmp_path, capsys):
    from tests.conftest import installed_command

    dragmesh2 = installed_command()

    assert dragmesh2(["inspect", str(tmp_path / "missing")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err


def test_zero_range_joint_is_rejected(obj_copy):
    _edit_urdf(obj_copy, 'upper="1.6399113651738721"', 'upper="0.0"', count=2)
    with pytest.raises(DragMeshError, match="zero motion range"):
        load_gapartnet(obj_copy)


def test_missing_annotation_falls_back_to_semantics(obj_copy):
    (obj_copy / "link_annotation_gapartnet.json").unlink()
    obj = load_gapartnet(obj_copy)
    assert obj.target.joint.is_revolute and obj.target.handle.source == "handle"
    assert json.dumps(obj.summary())  # JSON-ready


@pytest.mark.parametrize("name", ["mobility_annotation_gapartnet.urdf", "link_annotation_gapartnet.json", "meta.json",
                                  "semantics_gapartnet.txt"])
def test_an_object_file_symlinked_out_of_its_folder_is_refused(tmp_path, name):
    """Each file the importer opens by name, moved beside the folder (where it would load as it is) and left as a
    symlink in it, is one error line naming the file and the folder."""
    folder = tmp_path / "object"
    shutil.copytree(packaged_object("door_cabinet_0000"), folder)
    if name == "semantics_gapartnet.txt":  # read only without the link annotation
        (folder / "link_annotation_gapartnet.json").unlink()
    outside = (folder / name).rename(tmp_path / name)
    (folder / name).symlink_to(outside)
    with pytest.raises(DragMeshError) as e:
        load_gapartnet(folder)
    msg = str(e.value)
    assert "\n" not in msg and f"{folder / name} resolves to {outside}, outside the object folder {folder}" in msg


def test_a_door_closed_at_zero_that_opens_towards_negative_angles_loads_as_its_positive_twin(tmp_path):
    """GAPartNet's [-90 deg, 0] doors: annotated at the URDF's zero pose, which is the upper end of their range. The
    twin of the packaged door with the axis reversed and the range negated is read as the door itself (the axis
    reversed back, closed at its lower limit 0), every link posed as the original's, and its scene the original's."""
    source = packaged_object("door_cabinet_0000")
    twin = tmp_path / "door_twin"
    shutil.copytree(source, twin)
    path = twin / "mobility_annotation_gapartnet.urdf"
    text = path.read_text()
    flipped = text.replace('<axis xyz="0.000000 1.000000 0.000000"/>\n\t\t<child link="link_door"/>',
                           '<axis xyz="0.000000 -1.000000 0.000000"/>\n\t\t<child link="link_door"/>')
    flipped = flipped.replace('<limit lower="0.0" upper="1.9572"/>', '<limit lower="-1.9572" upper="0.0"/>')
    assert flipped.count("-1.9572") == 1 and flipped.count("-1.000000 0.000000") == 1
    path.write_text(flipped)
    original, door = load_gapartnet(source), load_gapartnet(twin)
    (j,) = [j for j in door.joints if j.name == "joint_door"]
    (o,) = [j for j in original.joints if j.name == "joint_door"]
    assert (j.lower, j.upper) == (o.lower, o.upper) == (0.0, 1.9572)
    np.testing.assert_allclose(j.axis, o.axis)
    np.testing.assert_allclose(j.origin, o.origin)
    for name, link in original.links.items():
        np.testing.assert_allclose(door.links[name].pose, link.pose, atol=1e-12)
    assert door.target.joint.name == "joint_door" and door.target.handle.link == original.target.handle.link
    assert build_scene(door).xml == build_scene(original).xml  # the same scene: the same expert, the same task
