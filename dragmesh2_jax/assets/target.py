"""The interaction target of a GAPartNet object: its annotated parts, the target part and driving joint, and the
handle's grasp frame (object frame, unscaled, closed configuration; see ``dragmesh2_jax.assets.urdf``).

Target selection follows the paper's Appendix B: parts whose category contains ``slider``/``drawer`` first,
then ``door``, else the last movable part; the handle is the one attached to the target part (kinematic
child) nearest its front face, else any handle nearest the front face, else the front face itself.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dragmesh2_jax.assets.urdf import Joint
from dragmesh2_jax.errors import DragMeshError


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
