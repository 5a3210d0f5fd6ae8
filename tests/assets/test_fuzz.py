"""A seeded fuzz of the importer: mutated copies of a procedural object (truncated or emptied files, deleted or
duplicated lines, numbers swapped for 0 / 1e9 / inf / nan, dropped attributes) each load into a scene or give one
error line naming the problem, never a traceback."""

import random
import re
import shutil

import pytest

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.scene import build_scene

SOURCE = packaged_object("door_cabinet_0000")
FILES = ("mobility_annotation_gapartnet.urdf", "link_annotation_gapartnet.json", "mobility_v2.json", "meta.json",
         "semantics_gapartnet.txt", "textured_objs/original-0.obj")
NUMBER = re.compile(r"-?\d+\.?\d*(e-?\d+)?")
ATTRIBUTE = re.compile(r'\s\w+="[^"]*"')


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


@pytest.mark.parametrize("seed", range(64))
def test_a_mutated_object_loads_or_is_one_error_line(tmp_path, seed):
    rng = random.Random(seed)
    folder = tmp_path / "obj"
    shutil.copytree(SOURCE, folder)
    name = rng.choice(FILES)
    what, text = mutate(rng, (folder / name).read_text())
    (folder / name).write_text(text)
    try:
        build_scene(load_gapartnet(folder), use_cache=False)
    except DragMeshError as e:
        assert "\n" not in str(e), (name, what)
