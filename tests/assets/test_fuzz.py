"""A seeded fuzz of the importer: mutated copies of a procedural object (truncated or emptied files, deleted or
duplicated lines, numbers swapped for 0 / 1e9 / inf / nan, dropped attributes) each give one error line naming the
problem, never a traceback, or load into a sound scene: a finite target range that opens, a handle on its own mesh
whose grasp normal points out of the part, a model of finite numbers and an expert drag within its cap. The numeric
fields are also set one by one to NaN, infinity and +-1e9, with the same two outcomes."""

import random
import re
import shutil

import numpy as np
import pytest

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.assets.urdf import load_link_vertices
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.scene import build_scene
from dragmesh2_jax.trajectory.generator import GeneratorParams, drag_extent

SOURCE = packaged_object("door_cabinet_0000")
FILES = ("mobility_annotation_gapartnet.urdf", "link_annotation_gapartnet.json", "mobility_v2.json", "meta.json",
         "semantics_gapartnet.txt", "textured_objs/original-0.obj")
URDF, ANNOTATION = FILES[:2]
NUMBER = re.compile(r"-?\d+\.?\d*(e-?\d+)?")
ATTRIBUTE = re.compile(r'\s\w+="[^"]*"')
MODEL_ARRAYS = ("jnt_range", "qpos0", "body_pos", "body_quat", "body_mass", "body_inertia", "geom_pos", "geom_size",
                "site_pos", "dof_damping")


def mutate(rng: random.Random, text: str) -> tuple[str, str]:
    lines = text.splitlines(keepends=True)
    kind = rng.choice(("truncate", "empty", "delete line", "duplicate line", "number", "attribute"))
    i = rng.randrange(len(lines)) if lines else 0
    if kind == "truncate":
        return kind, text[: rng.randrange(max(len(text), 1))]
    if kind == "empty":
        return kind, ""
    if kind == "delete line":
        return kind, "".join(lines[:i] + lines[i + 1:])
    if kind == "duplicate line":
        return kind, "".join(lines[: i + 1] + lines[i:])
    if kind == "number":
        spots = list(NUMBER.finditer(text))
        if spots:
            m = rng.choice(spots)
            bad = rng.choice(("0", "1e9", "inf", "nan", "-1e9"))
            return f"number -> {bad}", text[: m.start()] + bad + text[m.end():]
    spots = list(ATTRIBUTE.finditer(text))
    if not spots:
        return "unchanged", text
    m = rng.choice(spots)
    return "attribute dropped", text[: m.start()] + text[m.end():]


def _mesh_box(obj, link: str) -> tuple[np.ndarray, np.ndarray]:
    v = load_link_vertices(obj.links[link])
    return v.min(0), v.max(0)


def loads_soundly_or_is_one_error_line(folder, what: str) -> None:
    """The object folder gives one DragMeshError line, or an object and scene that are sound (see the module)."""
    try:
        obj = load_gapartnet(folder)
        scene = build_scene(obj, use_cache=False)
    except DragMeshError as e:
        assert "\n" not in str(e), what
        return
    t, h = obj.target, obj.target.handle
    assert np.isfinite([t.joint.lower, t.joint.upper]).all() and t.joint.upper > t.joint.lower, what
    lo, hi = _mesh_box(obj, h.link)
    assert np.all(h.centre >= lo - 1e-3) and np.all(h.centre <= hi + 1e-3), f"{what}: the handle is off its mesh"
    part_lo, part_hi = _mesh_box(obj, t.part.link)
    assert (h.centre - (part_lo + part_hi) / 2) @ h.normal > 0, f"{what}: the grasp normal points into the part"
    for name in MODEL_ARRAYS:
        assert np.isfinite(getattr(scene.model, name)).all(), f"{what}: model.{name} is not finite"
    p = GeneratorParams()
    assert 0 < drag_extent(scene, p) <= (p.max_drag_angle if t.joint.is_revolute else p.max_drag_distance), what


@pytest.mark.parametrize("seed", range(64))
def test_a_mutated_object_loads_soundly_or_is_one_error_line(tmp_path, monkeypatch, seed):
    monkeypatch.chdir(tmp_path)  # MuJoCo logs a warning (a NaN in the XML) to ./MUJOCO_LOG.TXT
    rng = random.Random(seed)
    folder = tmp_path / "obj"
    shutil.copytree(SOURCE, folder)
    name = rng.choice(FILES)
    what, text = mutate(rng, (folder / name).read_text())
    (folder / name).write_text(text)
    loads_soundly_or_is_one_error_line(folder, f"{name}: {what}")


HINGE = '<origin xyz="0.440995 0.000000 0.372950"/>'
AXIS = '<axis xyz="0.000000 1.000000 0.000000"/>'
DOOR_X, HANDLE_X = "-0.37294965609839986", "-0.44445998272625636"  # the first corner's x of each annotated box


@pytest.mark.parametrize("name, old, new", [
    pytest.param(URDF, 'upper="1.9572"', 'upper="nan"', id="upper=nan"),
    pytest.param(URDF, 'upper="1.9572"', 'upper="inf"', id="upper=inf"),
    pytest.param(URDF, 'upper="1.9572"', 'upper="1e9"', id="upper=1e9"),  # harmless: the expert drags 60 deg
    pytest.param(URDF, 'upper="1.9572"', 'upper="-inf"', id="upper=-inf"),
    pytest.param(URDF, 'upper="1.9572"', 'upper="wide"', id="upper=word"),
    pytest.param(URDF, 'lower="0.0"', 'lower="nan"', id="lower=nan"),
    pytest.param(URDF, 'lower="0.0"', 'lower="-inf"', id="lower=-inf"),
    pytest.param(URDF, 'lower="0.0"', 'lower="-1e9"', id="lower=-1e9"),
    pytest.param(URDF, HINGE, HINGE.replace("0.440995", "nan"), id="hinge origin=nan"),
    pytest.param(URDF, HINGE, HINGE.replace("0.440995", "1e9"), id="hinge origin=1e9"),
    pytest.param(URDF, AXIS, AXIS.replace("1.000000", "inf"), id="axis=inf"),
    pytest.param(URDF, AXIS, AXIS.replace("1.000000", "1e9"), id="axis=1e9"),  # normalised: harmless
    pytest.param(ANNOTATION, DOOR_X, "NaN", id="door box=NaN"),
    pytest.param(ANNOTATION, HANDLE_X, "Infinity", id="handle box=Infinity"),
    pytest.param(ANNOTATION, DOOR_X, "-1e9", id="door box=-1e9"),
    pytest.param(ANNOTATION, HANDLE_X, "-1e9", id="handle box=-1e9"),
])
def test_a_non_finite_or_absurd_number_is_one_error_line_or_harmless(tmp_path, monkeypatch, name, old,
                                                                      new):
    """A joint limit, joint origin or axis of the URDF, or a box corner of the annotation set to NaN, infinity or
    +-1e9 is one error line, or the object still loads soundly (finite range, handle on its mesh, normal out of the
    part, finite model, bounded expert drag)."""
    monkeypatch.chdir(tmp_path)  # MuJoCo logs a warning (a NaN in the XML) to ./MUJOCO_LOG.TXT
    folder = tmp_path / "obj"
    shutil.copytree(SOURCE, folder)
    text = (folder / name).read_text()
    assert old in text
    (folder / name).write_text(text.replace(old, new, 1))
    loads_soundly_or_is_one_error_line(folder, f"{name}: {old} -> {new}")
