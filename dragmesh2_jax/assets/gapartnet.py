"""GAPartNet / PartNet-Mobility object import: a plain data model of links, joints, parts and handles.

Frames and units: everything here is in the **object frame**, the URDF ``base`` frame (z-up for
PartNet-Mobility, whose y-up meshes are rotated by the root fixed joint), unscaled, with every joint at the
closed configuration (its lower limit). The scene (``dragmesh2_jax.scene``) scales and places it in the world.

Target selection follows the paper's Appendix B: parts whose category contains ``slider``/``drawer`` first,
then ``door``, else the last movable part; the handle is the one attached to the target part (kinematic
child) nearest its front face, else any handle nearest the front face, else the front face itself.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh
from defusedxml import ElementTree as SafeET

from dragmesh2_jax.errors import DragMeshError

URDF_CANDIDATES = ("mobility_annotation_gapartnet.urdf", "mobility.urdf")
MOVABLE = ("revolute", "prismatic", "continuous")
KNOWN_JOINT_TYPES = (*MOVABLE, "fixed")


@dataclass(frozen=True)
class MeshRef:
    """One mesh file of a link, with its pose in the link frame (4x4)."""

    path: Path
    transform: np.ndarray = field(repr=False)
    collision: bool


@dataclass(frozen=True)
class Link:
    name: str
    meshes: tuple[MeshRef, ...]
    pose: np.ndarray = field(repr=False)  # 4x4 link frame in the object frame, closed configuration


@dataclass(frozen=True)
class Joint:
    """A URDF joint. ``origin``/``axis`` are in the object frame (closed configuration); limits in URDF
    units (m, rad, unscaled). ``type`` is one of revolute | prismatic | continuous | fixed."""

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray
    lower: float
    upper: float

    @property
    def movable(self) -> bool:
        return self.type in MOVABLE

    @property
    def is_revolute(self) -> bool:
        return self.type in ("revolute", "continuous")


@dataclass(frozen=True)
class Part:
    """A GAPartNet part: link, category (e.g. ``slider_drawer``, ``hinge_door``, ``line_fixed_handle``) and its
    oriented box as 8 corners (object frame)."""

    link: str
    category: str
    bbox: np.ndarray = field(repr=False)

    @property
    def centre(self) -> np.ndarray:
        return self.bbox.mean(axis=0)

    @property
    def is_handle(self) -> bool:
        return "handle" in self.category


@dataclass(frozen=True)
class HandleFrame:
    """Grasp frame of the handle (object frame, unscaled): centre, unit long axis, unit outward normal,
    unit short axis, thickness along the normal, width along the short axis, length along the long axis.
    ``source`` is ``handle`` or ``front_face`` (no handle annotation: the target part's front face)."""

    centre: np.ndarray
    long_axis: np.ndarray
    normal: np.ndarray
    short_axis: np.ndarray
    thickness: float
    width: float
    length: float
    source: str
    link: str | None

    def corners(self) -> np.ndarray:
        """The 8 corners of the handle's box (object frame, unscaled)."""
        s = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=np.float64) / 2
        axes = np.stack([self.length * self.long_axis, self.width * self.short_axis,
                              self.thickness * self.normal])
        return self.centre + s @ axes

    def scaled(self, scale: float, position=(0.0, 0.0, 0.0)) -> HandleFrame:
        """The same frame in a world where the object is scaled by ``scale`` and moved to ``position``."""
        return HandleFrame(
            centre=np.asarray(position) + scale * self.centre, long_axis=self.long_axis, normal=self.normal,
            short_axis=self.short_axis, thickness=scale * self.thickness, width=scale * self.width,
            length=scale * self.length, source=self.source, link=self.link,
        )


@dataclass(frozen=True)
class Target:
    """The interaction target: part, its driving joint, handle frame, and the front-face normal."""

    part: Part
    joint: Joint
    handle: HandleFrame
    front_normal: np.ndarray
    attached_links: tuple[str, ...]  # the target link and every link welded to it (handles, ...)


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


# ----------------------------------------------------------------------------------------------- parsing


def _read_json(path: Path):
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise DragMeshError(f"{path}: malformed JSON ({e.msg} at line {e.lineno})") from None
    except (OSError, UnicodeDecodeError) as e:
        raise DragMeshError(f"{path}: cannot read ({e})") from None


def _floats(text: str | None, n: int, default, where: str) -> np.ndarray:
    if text is None:
        return np.asarray(default, dtype=np.float64)
    try:
        vals = [float(x) for x in text.split()]
    except ValueError:
        raise DragMeshError(f"{where}: expected {n} numbers, got {text!r}") from None
    if len(vals) != n or not np.all(np.isfinite(vals)):
        raise DragMeshError(f"{where}: expected {n} finite numbers, got {text!r}")
    return np.asarray(vals, dtype=np.float64)


def _rpy_matrix(rpy) -> np.ndarray:
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx  # URDF: fixed-axis roll, pitch, yaw


def _origin(el, where: str) -> np.ndarray:
    T = np.eye(4)
    if el is not None:
        T[:3, :3] = _rpy_matrix(_floats(el.get("rpy"), 3, (0, 0, 0), where))
        T[:3, 3] = _floats(el.get("xyz"), 3, (0, 0, 0), where)
    return T


def _motion(joint_type: str, axis: np.ndarray, q: float) -> np.ndarray:
    T = np.eye(4)
    if joint_type == "prismatic":
        T[:3, 3] = axis * q
    elif joint_type in ("revolute", "continuous"):
        T[:3, :3] = axis_angle_matrix(axis, q)
    return T


def axis_angle_matrix(axis, angle: float) -> np.ndarray:
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def find_urdf(folder: Path) -> Path:
    for name in URDF_CANDIDATES:
        if (folder / name).is_file():
            return folder / name
    raise DragMeshError(f"{folder}: no URDF found (expected {' or '.join(URDF_CANDIDATES)})")


#: The largest joint limit read: a revolute joint turns at most a full turn either way; a prismatic part of an
#: object in GAPartNet's unit-sized frame slides at most this far.
MAX_REVOLUTE_LIMIT, MAX_PRISMATIC_LIMIT = 2 * np.pi, 10.0


def _limit(lim, key: str, jtype: str, where: str) -> float:
    """A joint's ``<limit lower/upper>`` (0 where absent): a finite number within a joint's possible motion."""
    text = lim.get(key, "0") if lim is not None else "0"
    try:
        value = float(text)
    except ValueError:
        raise DragMeshError(f"{where}: limit {key}={text!r} is not a number") from None
    bound = MAX_PRISMATIC_LIMIT if jtype == "prismatic" else MAX_REVOLUTE_LIMIT
    if not abs(value) <= bound:
        raise DragMeshError(f"{where}: limit {key}={text!r} is not a finite number within +-{bound:g}")
    return value


def parse_urdf(urdf: Path) -> tuple[dict[str, Link], tuple[Joint, ...], str]:
    """Links (meshes and closed-configuration poses), joints (object frame), and the root link name."""
    try:
        root = SafeET.parse(str(urdf)).getroot()
    except SafeET.ParseError as e:
        raise DragMeshError(f"{urdf}: malformed XML ({e})") from None
    except Exception as e:  # defusedxml raises its own types for entity attacks
        raise DragMeshError(f"{urdf}: unsafe or unreadable XML ({type(e).__name__})") from None
    if root.tag != "robot":
        raise DragMeshError(f"{urdf}: not a URDF (root element <{root.tag}>, expected <robot>)")
    folder = urdf.parent

    raw_links: dict[str, list[MeshRef]] = {}
    for link in root.findall("link"):
        name = link.get("name")
        if not name:
            raise DragMeshError(f"{urdf}: a <link> has no name")
        meshes = []
        for kind in ("visual", "collision"):
            for el in link.findall(kind):
                mesh = el.find("geometry/mesh")
                if mesh is None:
                    continue
                fn = mesh.get("filename", "")
                path = folder / fn
                if not fn or not path.is_file():
                    raise DragMeshError(f"{urdf}: link {name!r} references missing mesh {fn!r}")
                meshes.append(MeshRef(path, _origin(el.find("origin"), f"{urdf}: link {name}"), kind == "collision"))
        raw_links[name] = meshes

    joints_raw = []
    for j in root.findall("joint"):
        name, jtype = j.get("name", "?"), j.get("type", "")
        where = f"{urdf}: joint {name!r}"
        if jtype not in KNOWN_JOINT_TYPES:
            known = ", ".join(KNOWN_JOINT_TYPES)
            raise DragMeshError(f"{where}: unknown joint type {jtype!r} (expected one of {known})")
        parent, child = j.find("parent"), j.find("child")
        if parent is None or child is None:
            raise DragMeshError(f"{where}: missing <parent> or <child>")
        p, c = parent.get("link"), child.get("link")
        if p not in raw_links or c not in raw_links:
            raise DragMeshError(f"{where}: refers to unknown link {p if p not in raw_links else c!r}")
        axis = _floats(j.find("axis").get("xyz") if j.find("axis") is not None else None, 3, (1, 0, 0), where)
        if jtype in MOVABLE and np.linalg.norm(axis) < 1e-9:
            raise DragMeshError(f"{where}: zero joint axis")
        lim = j.find("limit")
        lower, upper = (_limit(lim, k, jtype, where) for k in ("lower", "upper"))
        if jtype == "continuous":
            lower, upper = (lower, upper) if upper > lower else (0.0, np.pi)
        joints_raw.append((name, jtype, p, c, _origin(j.find("origin"), where), axis / max(np.linalg.norm(axis), 1e-12),
                           lower, upper))

    children = {c for (_, _, _, c, *_) in joints_raw}
    roots = [n for n in raw_links if n not in children]
    if len(roots) != 1:
        raise DragMeshError(f"{urdf}: expected one root link, found {roots}")
    root_name = roots[0]

    # Forward kinematics at the closed configuration (every joint at its lower limit).
    pose = {root_name: np.eye(4)}
    joints: list[Joint] = []
    pending = list(joints_raw)
    while pending:
        progressed = False
        for item in list(pending):
            name, jtype, p, c, T_origin, axis, lower, upper = item
            if p not in pose:
                continue
            T_joint = pose[p] @ T_origin
            q0 = lower if jtype in MOVABLE else 0.0
            pose[c] = T_joint @ _motion(jtype, axis, q0)
            joints.append(Joint(name, jtype, p, c, origin=T_joint[:3, 3].copy(),
                                axis=T_joint[:3, :3] @ axis, lower=lower, upper=upper))
            pending.remove(item)
            progressed = True
        if not progressed:
            raise DragMeshError(f"{urdf}: joint tree is disconnected or cyclic")
    links = {n: Link(n, tuple(m), pose[n]) for n, m in raw_links.items()}
    return links, tuple(joints), root_name


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
    path = folder / "link_annotation_gapartnet.json"
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
    sem = folder / "semantics_gapartnet.txt"
    sem = sem if sem.is_file() else folder / "semantics.txt"
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


# -------------------------------------------------------------------------------------- target selection


def welded_descendants(link: str, joints: tuple[Joint, ...]) -> tuple[str, ...]:
    """``link`` and every link attached to it through fixed joints only."""
    out, frontier = [link], [link]
    while frontier:
        cur = frontier.pop()
        for j in joints:
            if j.parent == cur and j.type == "fixed":
                out.append(j.child)
                frontier.append(j.child)
    return tuple(out)


def driving_joint(link: str, joints: tuple[Joint, ...]) -> Joint | None:
    """The first movable joint on the path from ``link`` to the root (through fixed joints)."""
    by_child = {j.child: j for j in joints}
    cur = link
    while cur in by_child:
        j = by_child[cur]
        if j.movable:
            return j
        cur = j.parent
    return None


def select_target_part(parts: list[Part], joints: tuple[Joint, ...]) -> Part:
    """Appendix B: slider/drawer first, then door, else the last movable non-handle part."""
    movable = [p for p in parts if not p.is_handle and driving_joint(p.link, joints) is not None]
    if not movable:
        raise DragMeshError("no movable part: no annotated part is driven by a revolute or prismatic joint")
    for keys in (("slider", "drawer"), ("door",)):
        for p in movable:
            if any(k in p.category for k in keys):
                return p
    return movable[-1]


def _box_axes(bbox: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Three edge vectors from corner 0 (to corners 1, 3, 4) of an 8-corner box."""
    edges = np.stack([bbox[1] - bbox[0], bbox[3] - bbox[0], bbox[4] - bbox[0]])
    return edges, np.linalg.norm(edges, axis=1)


def opening_direction(part: Part, joint: Joint, probe: np.ndarray | None = None) -> np.ndarray:
    """Unit direction in which ``probe`` (default: the part centre) moves as q increases (opening)."""
    if not joint.is_revolute:
        return joint.axis / np.linalg.norm(joint.axis)
    p = part.centre if probe is None else probe
    v = np.cross(joint.axis, p - joint.origin)
    n = np.linalg.norm(v)
    if n < 1e-9:
        raise DragMeshError(f"joint {joint.name}: the part centre lies on the hinge axis")
    return v / n


def front_normal(part: Part, joint: Joint) -> np.ndarray:
    """Outward normal of the part's front face: the box face normal best aligned with the opening motion."""
    edges, lengths = _box_axes(part.bbox)
    dirs = edges / np.maximum(lengths[:, None], 1e-12)
    move = opening_direction(part, joint)
    k = int(np.argmax(np.abs(dirs @ move)))
    return dirs[k] * np.sign(dirs[k] @ move)


def half_thickness(part: Part, normal: np.ndarray) -> float:
    """Half the part box's extent along ``normal`` (its front face lies this far out of its centre)."""
    edges, _ = _box_axes(part.bbox)
    return 0.5 * float(np.abs(edges @ normal).max())


def front_face_centre(part: Part, normal: np.ndarray) -> np.ndarray:
    return part.centre + normal * half_thickness(part, normal)


def protrusion(part: Part, point: np.ndarray) -> np.ndarray:
    """Unit direction (one of the part box's edge axes, signed) along which ``point`` lies farthest outside
    the part box, in units of the box's half extents: the way a handle sticks out of its part."""
    edges, lengths = _box_axes(part.bbox)
    dirs = edges / np.maximum(lengths[:, None], 1e-12)
    u = (dirs @ (point - part.centre)) / np.maximum(lengths / 2, 1e-9)
    k = int(np.argmax(np.abs(u)))
    return dirs[k] * np.sign(u[k] if u[k] != 0 else 1.0)


def graspable_box(box: np.ndarray, part: Part, normal: np.ndarray) -> np.ndarray:
    """The handle box ``box`` cut at the part's front face when it sticks out of both faces of the part (a door's
    double-sided knob, annotated as one box through the panel): the hand can only pull on the front side, the one
    the part moves towards. Any other box is returned as it is.

    The box is cut along its edge most aligned with ``normal``, so the result keeps GAPartNet's corner order."""
    half = half_thickness(part, normal)
    s = (box - part.centre) @ normal
    if not (s.min() < -half and s.max() > half):
        return box
    h_edges, _ = _box_axes(box)
    k = int(np.argmax(np.abs(h_edges @ normal) / np.maximum(np.linalg.norm(h_edges, axis=1), 1e-12)))
    e = h_edges[k]
    # the box is c0 + a e1 + b e3 + c e4 over [0, 1]^3; along e, keep the parameters in front of the face
    t_face = (half - s[0]) / (e @ normal)
    lo, hi = (t_face, 1.0) if e @ normal > 0 else (0.0, t_face)
    c0 = box[0] + lo * e
    scaled = h_edges.copy()
    scaled[k] = (hi - lo) * e
    e1, e3, e4 = scaled
    return np.stack([c0, c0 + e1, c0 + e1 + e3, c0 + e3, c0 + e4, c0 + e4 + e1, c0 + e4 + e1 + e3, c0 + e4 + e3])


def handle_frame(box: np.ndarray, normal_hint: np.ndarray, source: str, link: str | None,
                 thickness_override: float | None = None) -> HandleFrame:
    """Decompose an 8-corner box into (centre, long, normal, short, thickness). The normal is the box edge
    best aligned with ``normal_hint`` (the part's outward front normal); long/short are the other two by
    length. Robust to corner-order conventions; for GAPartNet handles it equals the reference's
    c0-c4 / c0-c1 / c0-c3 decomposition."""
    edges, lengths = _box_axes(box)
    if np.any(lengths < 1e-9):
        # flat box: fall back to an orthonormal frame from the hint
        lengths = np.maximum(lengths, 1e-6)
    dirs = edges / lengths[:, None]
    k = int(np.argmax(np.abs(dirs @ normal_hint)))
    normal = dirs[k] * (1.0 if dirs[k] @ normal_hint >= 0 else -1.0)
    rest = [i for i in range(3) if i != k]
    rest.sort(key=lambda i: -lengths[i])
    long_axis = dirs[rest[0]] - (dirs[rest[0]] @ normal) * normal
    long_axis /= np.linalg.norm(long_axis)
    short_axis = np.cross(normal, long_axis)
    return HandleFrame(
        centre=box.mean(axis=0), long_axis=long_axis, normal=normal, short_axis=short_axis,
        thickness=float(lengths[k]) if thickness_override is None else thickness_override,
        width=float(lengths[rest[1]]), length=float(lengths[rest[0]]), source=source, link=link,
    )


def select_target(parts: list[Part], joints: tuple[Joint, ...], joint_name: str | None = None) -> Target:
    """The target part, joint and handle frame: by the Appendix B rule (``select_target_part``), or the part
    driven by ``joint_name`` (a reference trajectory that moves another part)."""
    if joint_name is None:
        part = select_target_part(parts, joints)
    else:
        driven = [p for p in parts if not p.is_handle and getattr(driving_joint(p.link, joints), "name", None)
                  == joint_name]
        if not driven:
            raise DragMeshError(f"no annotated part is driven by joint {joint_name!r}")
        part = driven[0]
    joint = driving_joint(part.link, joints)
    assert joint is not None
    if not joint.upper - joint.lower > 1e-6:
        raise DragMeshError(f"joint {joint.name}: zero motion range [{joint.lower}, {joint.upper}]")
    normal = front_normal(part, joint)
    face = front_face_centre(part, normal)
    attached = welded_descendants(part.link, joints)
    handles = [p for p in parts if p.is_handle]
    own = [h for h in handles if h.link in attached]
    pool = own or handles
    if pool:
        h = min(pool, key=lambda h: float(np.linalg.norm(h.centre - face)))
        box = graspable_box(h.bbox, part, normal)
        frame = handle_frame(box, protrusion(part, box.mean(axis=0)), "handle", h.link)
    else:
        frame = handle_frame(part.bbox, normal, "front_face", part.link, thickness_override=0.01)
        frame = HandleFrame(face, frame.long_axis, frame.normal, frame.short_axis, frame.thickness, frame.width,
                            frame.length, frame.source, frame.link)
    return Target(part=part, joint=joint, handle=frame, front_normal=normal, attached_links=attached)


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
    meta_path = folder / "meta.json"
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


# ---------------------------------------------------------------------------------- meshes of a link
def load_mesh(path: Path):
    """(vertices, faces) of a mesh file; a clear error for an unreadable or non-finite one."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            logging.getLogger("trimesh").setLevel(logging.ERROR)
            mesh = trimesh.load(str(path), force="mesh", process=False, skip_materials=True)
    except Exception as e:
        raise DragMeshError(f"{path}: cannot read mesh ({type(e).__name__}: {e})") from None
    v = np.asarray(getattr(mesh, "vertices", np.zeros((0, 3))), dtype=np.float64)
    f = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))), dtype=np.int64)
    if len(v) and not np.all(np.isfinite(v)):
        raise DragMeshError(f"{path}: mesh has non-finite vertices")
    return v, f


def transform_points(v: np.ndarray, T: np.ndarray) -> np.ndarray:
    return v @ T[:3, :3].T + T[:3, 3]


def mesh_files(link: Link) -> list[MeshRef]:
    """Collision meshes of a link (visual ones where it has none), each file once."""
    refs = [m for m in link.meshes if m.collision] or list(link.meshes)
    seen, out = set(), []
    for m in refs:
        key = (m.path, m.transform.tobytes())
        if key not in seen:
            seen.add(key)
            out.append(m)
    return out


def load_link_vertices(link: Link) -> np.ndarray:
    """All vertices of a link's meshes in the object frame (closed configuration)."""
    vs = [transform_points(load_mesh(m.path)[0], link.pose @ m.transform) for m in mesh_files(link)]
    return np.concatenate(vs) if vs else np.zeros((0, 3))
