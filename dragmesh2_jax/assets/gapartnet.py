"""GAPartNet / PartNet-Mobility object import: ``load_gapartnet`` reads an object folder into a plain data
model of links, joints, parts and handles.

Frames and units: everything here is in the **object frame**, the URDF ``base`` frame (z-up for
PartNet-Mobility, whose y-up meshes are rotated by the root fixed joint), unscaled, with every joint at the
closed configuration (its lower limit). The scene (``dragmesh2_jax.scene``) scales and places it in the world.

The URDF (links, joints, meshes) is read by ``dragmesh2_jax.assets.urdf``; the target part, joint and handle
frame are chosen by ``dragmesh2_jax.assets.target`` (paper Appendix B). This module reads the part annotations and
``meta.json`` and puts the object together.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dragmesh2_jax.assets.target import Part, Target, select_target
from dragmesh2_jax.assets.urdf import Joint, Link, find_urdf, inside_folder, load_link_vertices, parse_urdf
from dragmesh2_jax.errors import DragMeshError


@dataclass(frozen=True)
class GAPartNetObject:
    folder: Path
    object_id: str
    category: str
    urdf: Path
    links: dict[str, Link]
    joints: tuple[Joint, ...]
    parts: tuple[Part, ...]
    target: Target
    root: str

    @property
    def movable_joints(self) -> tuple[Joint, ...]:
        return tuple(j for j in self.joints if j.movable)

    @property
    def handles(self) -> tuple[Part, ...]:
        return tuple(p for p in self.parts if p.is_handle)

    def with_target(self, joint_name: str) -> GAPartNetObject:
        """The same object with the part that ``joint_name`` drives as the target (and that part's handle)."""
        if joint_name == self.target.joint.name:
            return self
        try:
            return dataclasses.replace(self, target=select_target(list(self.parts), self.joints, joint_name))
        except DragMeshError as e:
            raise DragMeshError(f"{self.folder}: {e}") from None

    def joint_by_child(self, child: str) -> Joint | None:
        return next((j for j in self.joints if j.child == child), None)

    def summary(self) -> dict:
        """JSON-ready description (used by ``dragmesh2 inspect``)."""
        t = self.target
        h = t.handle
        return {
            "object_id": self.object_id,
            "category": self.category,
            "folder": str(self.folder),
            "movable_joints": [j.name for j in self.movable_joints],
            "target_part": {"link": t.part.link, "category": t.part.category},
            "target_joint": {
                "name": t.joint.name, "type": "revolute" if t.joint.is_revolute else "prismatic",
                "axis": _r(t.joint.axis), "origin": _r(t.joint.origin),
                "range": [float(t.joint.lower), float(t.joint.upper)],
            },
            "handle": {
                "source": h.source, "link": h.link, "centre": _r(h.centre), "long_axis": _r(h.long_axis),
                "normal": _r(h.normal), "short_axis": _r(h.short_axis), "thickness": round(h.thickness, 5),
                "width": round(h.width, 5), "length": round(h.length, 5),
            },
            "frame": "object (URDF base, z-up, unscaled, closed)",
        }


def _r(v) -> list[float]:
    return [round(float(x), 5) for x in np.asarray(v).ravel()]


# ------------------------------------------------------------------------------------------- annotations


def _read_json(path: Path):
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise DragMeshError(f"{path}: malformed JSON ({e.msg} at line {e.lineno})") from None
    except (OSError, UnicodeDecodeError) as e:
        raise DragMeshError(f"{path}: cannot read ({e})") from None


def _aabb_corners(lo, hi) -> np.ndarray:
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    return np.array([[x0, y1, z1], [x0, y0, z1], [x0, y0, z0], [x0, y1, z0],
                     [x1, y1, z1], [x1, y0, z1], [x1, y0, z0], [x1, y1, z0]], dtype=np.float64)


#: How far (a fraction of the link's mesh bounds' diagonal) an annotated box's centre may lie outside those bounds.
BOX_SLACK = 0.05


def _box_on_link(bbox: np.ndarray, link: Link, where: str) -> None:
    """An annotated part's box must sit on its link's meshes (the handle frame and the grasp normal come from it)."""
    v = load_link_vertices(link)
    if not len(v):
        return
    lo, hi = v.min(0), v.max(0)
    slack = BOX_SLACK * np.linalg.norm(hi - lo)
    centre = bbox.mean(0)
    if np.any(centre < lo - slack) or np.any(centre > hi + slack):
        raise DragMeshError(f"{where}: the annotated box (centre {np.round(centre, 3).tolist()}) lies off its link's "
                            f"meshes (bounds {np.round(lo, 3).tolist()} to {np.round(hi, 3).tolist()})")


def read_parts(folder: Path, links: dict[str, Link]) -> list[Part]:
    """GAPartNet parts from ``link_annotation_gapartnet.json``; without it, from ``semantics*.txt`` and the
    links' mesh bounding boxes (then the corner order carries no meaning; the front face is re-derived)."""
    path = inside_folder(folder, "link_annotation_gapartnet.json")
    parts: list[Part] = []
    if path.is_file():
        data = _read_json(path)
        if not isinstance(data, list):
            raise DragMeshError(f"{path}: expected a list of link annotations")
        for i, e in enumerate(data):
            if not isinstance(e, dict) or "link_name" not in e:
                raise DragMeshError(f"{path}: entry {i} has no 'link_name'")
            if not e.get("is_gapart"):
                continue
            try:
                bbox = np.asarray(e.get("bbox"), dtype=np.float64)
            except (TypeError, ValueError):  # ragged or non-numeric corners
                bbox = np.zeros(0)
            if bbox.shape != (8, 3) or not np.all(np.isfinite(bbox)):
                raise DragMeshError(f"{path}: entry {i} ({e['link_name']}) bbox is not 8 finite corners")
            if e["link_name"] not in links:
                raise DragMeshError(f"{path}: entry {i} names link {e['link_name']!r}, which the URDF lacks")
            _box_on_link(bbox, links[e["link_name"]], f"{path}: entry {i} ({e['link_name']})")
            parts.append(Part(e["link_name"], str(e.get("category", "")), bbox))
        return parts
    sem = inside_folder(folder, "semantics_gapartnet.txt")
    sem = sem if sem.is_file() else inside_folder(folder, "semantics.txt")
    if not sem.is_file():
        raise DragMeshError(f"{folder}: no link_annotation_gapartnet.json or semantics file to find parts in")
    for line in sem.read_text().splitlines():
        toks = line.split()
        if len(toks) < 3 or toks[0] not in links:
            continue
        v = load_link_vertices(links[toks[0]])
        if len(v):
            parts.append(Part(toks[0], f"{toks[1]}_{toks[2]}", _aabb_corners(v.min(0), v.max(0))))
    return parts


# ----------------------------------------------------------------------------------------------- loading


def load_gapartnet(folder: str | Path) -> GAPartNetObject:
    """Read a GAPartNet / PartNet-Mobility object folder into a :class:`GAPartNetObject`.

    Reads ``mobility_annotation_gapartnet.urdf`` (or ``mobility.urdf``), ``link_annotation_gapartnet.json``,
    ``meta.json`` and the meshes the URDF references; ``semantics*.txt`` is optional; ``mobility_v2.json`` is not
    read (the URDF holds the joints).
    Raises :class:`DragMeshError` (one line, naming the file) on anything unusable.
    """
    folder = Path(folder)
    if not folder.exists():
        raise DragMeshError(f"{folder}: no such folder")
    if not folder.is_dir():
        raise DragMeshError(f"{folder}: not a folder")
    urdf = find_urdf(folder)
    links, joints, root = parse_urdf(urdf)
    if not any(j.movable for j in joints):
        raise DragMeshError(f"{urdf}: object has no movable (revolute or prismatic) joint")
    meta_path = inside_folder(folder, "meta.json")
    meta = _read_json(meta_path) if meta_path.is_file() else {}
    if not isinstance(meta, dict):
        raise DragMeshError(f"{meta_path}: expected a JSON object")
    category = str(meta.get("model_cat", "Unknown"))
    object_id = str(meta.get("anno_id", folder.name))
    parts = read_parts(folder, links)
    try:
        target = select_target(parts, joints)
    except DragMeshError as e:
        raise DragMeshError(f"{folder}: {e}") from None
    return GAPartNetObject(folder=folder, object_id=object_id, category=category, urdf=urdf, links=links,
                           joints=joints, parts=tuple(parts), target=target, root=root)

