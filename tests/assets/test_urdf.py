"""URDF reading: nothing an object folder's URDF names reaches outside the folder, no mesh file over
``MAX_MESH_BYTES`` is read, and XML entities are refused, never expanded."""

import os

import pytest

from dragmesh2_jax.assets import urdf
from dragmesh2_jax.assets.urdf import load_link_vertices, parse_urdf
from dragmesh2_jax.errors import DragMeshError

TRIANGLE = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"  # a mesh trimesh loads


def _write_urdf(folder, mesh: str = "textured_objs/original-0.obj", doctype: str = "", name: str = "r"):
    """``folder``'s URDF: one link whose visual mesh is ``mesh``, after ``doctype``, the robot named ``name``."""
    path = folder / "mobility.urdf"
    path.write_text(f'<?xml version="1.0"?>\n{doctype}\n<robot name="{name}">\n<link name="base"><visual>'
                    f'<geometry><mesh filename="{mesh}"/></geometry></visual></link>\n</robot>\n')
    return path


@pytest.fixture
def folder(tmp_path):
    """An object folder in ``tmp_path`` with one mesh of its own, and a loadable mesh beside the folder,
    ``tmp_path / "outside.obj"``, which no reference from inside may reach."""
    obj = tmp_path / "object"
    (obj / "textured_objs").mkdir(parents=True)
    (obj / "textured_objs" / "original-0.obj").write_text(TRIANGLE)
    (tmp_path / "outside.obj").write_text(TRIANGLE)
    return obj


def _parse(folder, mesh: str):
    return parse_urdf(_write_urdf(folder, mesh))


def _refused(folder, **urdf_text) -> str:
    """The one-line error that reading ``folder``'s URDF (``_write_urdf``'s arguments) gives, naming the URDF."""
    with pytest.raises(DragMeshError) as e:
        parse_urdf(_write_urdf(folder, **urdf_text))
    msg = str(e.value)
    assert "\n" not in msg and str(folder / "mobility.urdf") in msg
    return msg


def test_a_mesh_inside_the_folder_loads(folder):
    links, _, root = _parse(folder, "textured_objs/original-0.obj")
    assert root == "base" and len(load_link_vertices(links["base"])) == 3


@pytest.mark.parametrize("mesh", ["../outside.obj", "textured_objs/../../outside.obj", "ABSOLUTE"])
def test_a_mesh_path_leaving_the_folder_is_refused_naming_it_and_the_folder(folder, mesh):
    mesh = str(folder.parent / "outside.obj") if mesh == "ABSOLUTE" else mesh
    msg = _refused(folder, mesh=mesh)
    assert repr(mesh) in msg and f"outside the object folder {folder}" in msg


def test_a_symlink_in_the_folder_pointing_out_of_it_is_refused(folder):
    (folder / "textured_objs" / "link.obj").symlink_to(folder.parent / "outside.obj")
    msg = _refused(folder, mesh="textured_objs/link.obj")
    assert str((folder.parent / "outside.obj").resolve()) in msg and f"outside the object folder {folder}" in msg


def test_a_symlink_within_the_folder_is_followed(folder):
    (folder / "alias.obj").symlink_to("textured_objs/original-0.obj")
    links, _, _ = _parse(folder, "alias.obj")
    assert len(load_link_vertices(links["base"])) == 3


def test_a_symlink_loop_is_one_error_line(folder):
    (folder / "a.obj").symlink_to("b.obj")
    (folder / "b.obj").symlink_to("a.obj")
    assert "cannot resolve" in _refused(folder, mesh="a.obj")


def test_a_folder_reached_through_a_symlink_reads_its_own_meshes(folder, tmp_path):
    (tmp_path / "alias").symlink_to(folder)
    links, _, _ = _parse(tmp_path / "alias", "textured_objs/original-0.obj")
    assert len(load_link_vertices(links["base"])) == 3


def test_a_mesh_over_the_size_limit_is_refused_from_its_size_before_it_is_read(folder):
    # A sparse file: its size is over the limit, yet nothing is written or read. Parsing must refuse it, since
    # everything after (the collision cache's content hash, trimesh) reads the whole file.
    huge = folder / "textured_objs" / "huge.obj"
    with open(huge, "wb") as f:
        f.truncate(urdf.MAX_MESH_BYTES + 1)
    msg = _refused(folder, mesh="textured_objs/huge.obj")
    assert "'textured_objs/huge.obj'" in msg and f"{urdf.MAX_MESH_BYTES + 1} bytes" in msg
    assert str(urdf.MAX_MESH_BYTES) in msg


def test_a_mesh_of_exactly_the_size_limit_is_read_and_one_byte_over_is_not(folder, monkeypatch):
    size = os.path.getsize(folder / "textured_objs" / "original-0.obj")
    monkeypatch.setattr(urdf, "MAX_MESH_BYTES", size)
    links, _, _ = _parse(folder, "textured_objs/original-0.obj")
    assert len(load_link_vertices(links["base"])) == 3
    monkeypatch.setattr(urdf, "MAX_MESH_BYTES", size - 1)
    assert f"has {size} bytes, over the {size - 1}" in _refused(folder, mesh="textured_objs/original-0.obj")


# --------------------------------------------------------------------------------------------- XML entities

LAUGHS = "".join(f'<!ENTITY lol{i} "{f"&lol{i - 1};" * 10}">' for i in range(1, 10))


def test_a_billion_laughs_urdf_is_refused_not_expanded(folder):
    msg = _refused(folder, doctype=f'<!DOCTYPE robot [<!ENTITY lol0 "lol">{LAUGHS}]>', name="&lol9;")
    assert "entities" in msg and "lollol" not in msg


def test_an_external_entity_naming_a_file_outside_the_folder_is_refused_unread(folder):
    secret = folder.parent / "secret.txt"
    secret.write_text("the-secret-contents")
    msg = _refused(folder, doctype=f'<!DOCTYPE robot [<!ENTITY x SYSTEM "file://{secret}">]>', name="&x;")
    assert "entities" in msg and "the-secret-contents" not in msg
