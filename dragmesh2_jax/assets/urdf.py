"""URDF reading for GAPartNet / PartNet-Mobility objects: links with their meshes and closed-configuration poses,
joints in the object frame, and a link's mesh vertices.

Frames and units: the **object frame** is the URDF ``base`` frame (z-up for PartNet-Mobility, whose y-up meshes are
rotated by the root fixed joint), unscaled, with every joint at the closed configuration (its lower limit). The
closed configuration is the URDF's zero pose, where GAPartNet's annotated boxes fit the meshes: a joint whose range
ends at zero from below (closed at 0, opening towards -90 deg) is read with its axis reversed and its range negated,
so that its lower limit is that zero pose and opening raises it, as every other joint's.
"""

from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh
from defusedxml import DefusedXmlException
from defusedxml import ElementTree as SafeET

from dragmesh2_jax.errors import DragMeshError

URDF_CANDIDATES = ("mobility_annotation_gapartnet.urdf", "mobility.urdf")
MOVABLE = ("revolute", "prismatic", "continuous")
#: A limit within this of zero is the zero pose (rad or m, unscaled).
ZERO_POSE_TOL = 1e-6
KNOWN_JOINT_TYPES = (*MOVABLE, "fixed")
#: The largest mesh file read. The largest mesh of the GAPartNet test objects has 40 KB (45780's original-48.obj);
#: 64 MiB, over 1500 times that, leaves room for far finer meshes, while a larger one would be loaded whole into
#: memory and then hulled or decomposed: it is refused from its size, before anything reads it.
MAX_MESH_BYTES = 64 * 2**20


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


# ----------------------------------------------------------------------------------------------- parsing


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


def inside_folder(folder: Path, name: str, where: str | None = None) -> Path:
    """``folder / name``, refused where it lies outside ``folder`` once symlinks are followed: nothing an object
    folder holds (a ``../`` or absolute path in its files, a symlink pointing out) opens a file elsewhere.
    ``where`` names the reference in the error (default: the path itself)."""
    path = folder / name
    try:
        real = path.resolve()
    except (OSError, RuntimeError) as e:  # RuntimeError: a symlink loop
        raise DragMeshError(f"{where or path}: cannot resolve ({e})") from None
    if not real.is_relative_to(folder.resolve()):
        raise DragMeshError(f"{where or path} resolves to {real}, outside the object folder {folder}")
    return path


def find_urdf(folder: Path) -> Path:
    for name in URDF_CANDIDATES:
        path = inside_folder(folder, name)
        if path.is_file():
            return path
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


def _mesh_path(folder: Path, fn: str, where: str) -> Path:
    """The mesh file ``fn`` a link names: an existing file inside ``folder`` of at most ``MAX_MESH_BYTES``."""
    path = inside_folder(folder, fn, f"{where}: mesh {fn!r}")
    if not fn or not path.is_file():
        raise DragMeshError(f"{where} references missing mesh {fn!r}")
    size = path.stat().st_size
    if size > MAX_MESH_BYTES:
        raise DragMeshError(f"{where}: mesh {fn!r} has {size} bytes, over the {MAX_MESH_BYTES} a mesh may have")
    return path


def parse_urdf(urdf: Path) -> tuple[dict[str, Link], tuple[Joint, ...], str]:
    """Links (meshes and closed-configuration poses), joints (object frame), and the root link name."""
    try:
        root = SafeET.parse(str(urdf)).getroot()
    except SafeET.ParseError as e:
        raise DragMeshError(f"{urdf}: malformed XML ({e})") from None
    except DefusedXmlException as e:  # an entity could expand without bound or pull in a file from elsewhere
        raise DragMeshError(f"{urdf}: refused XML entities, which are never expanded ({e})") from None
    except Exception as e:  # whatever else stops the read (permissions, I/O): one line, never a traceback
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
                path = _mesh_path(folder, mesh.get("filename", ""), f"{urdf}: link {name!r}")
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
        elif jtype in MOVABLE and abs(upper) <= ZERO_POSE_TOL < -lower:  # closed at zero, opening negative
            axis, lower, upper = -axis, 0.0 - upper, 0.0 - lower  # 0.0 - x: no negative zero
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
