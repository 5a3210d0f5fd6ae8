"""Box geometry and the handles of the procedural objects (``assets/procedural.py``): line handles (a bar on two
posts), edge pulls (a J-profile along a part's edge) and round knobs, each with its GAPartNet annotation box.

Every handle is built on a face whose outward normal is -x (the object's front) in the z-up object frame
(unscaled), from axis-aligned boxes. Bars, edge pulls and cabinet knobs are three boxes each, so the objects of one
category share one array structure whichever handle they draw (one compiled program trains several of them).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# PartNet-Mobility's root joint maps y-up mesh coordinates to the z-up base frame: base <- mesh.
R_ROOT = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
_OUT = np.array([-1.0, 0.0, 0.0])  # the front faces' outward normal


@dataclass
class Box:
    """An axis-aligned box in the z-up object frame."""

    lo: np.ndarray
    hi: np.ndarray

    def mesh_obj(self) -> str:
        """Wavefront OBJ of the box in the y-up mesh frame."""
        c = np.array([[x, y, z] for x in (self.lo[0], self.hi[0]) for y in (self.lo[1], self.hi[1])
                      for z in (self.lo[2], self.hi[2])])
        m = c @ R_ROOT  # mesh = R^T base
        faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
        lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in m]
        for a, b, cc, d in faces:
            lines.append(f"f {a + 1} {b + 1} {cc + 1}")
            lines.append(f"f {a + 1} {cc + 1} {d + 1}")
        return "\n".join(lines) + "\n"


def box(centre, half) -> Box:
    c, h = np.asarray(centre, float), np.asarray(half, float)
    return Box(c - h, c + h)


def gapartnet_corners(centre, long_axis, normal, length, depth, width) -> list[list[float]]:
    """8 corners in GAPartNet order: 0-3 outer face, c0-c4 = normal*depth, c0-c1 = long*length,
    c0-c3 = short*width with short = normal x long."""
    c, l, n = (np.asarray(v, float) for v in (centre, long_axis, normal))
    s = np.cross(n, l)
    outer = c + n * depth / 2
    top = [outer + l * length / 2 + s * width / 2, outer - l * length / 2 + s * width / 2,
           outer - l * length / 2 - s * width / 2, outer + l * length / 2 - s * width / 2]
    return [list(map(float, p)) for p in top + [p - n * depth for p in top]]


def line_handle(centre, long_axis, length, standoff, bar=0.025, depth: float | None = None):
    """A line handle: a bar ``standoff`` out along -x from the surface at ``centre[0]``, plus two posts. The bar is
    ``bar`` wide across the face and ``depth`` (default ``bar``) deep along the normal, so a thin handle can stand
    out little and still leave the fingers a gap behind it. Returns the boxes and the GAPartNet bbox."""
    c = np.asarray(centre, float)
    la = np.asarray(long_axis, float)
    depth = bar if depth is None else depth
    outer_x = c[0] - standoff
    half_long = np.abs(la) * length / 2
    short = np.cross(_OUT, la)
    half_short = np.abs(short) * bar / 2
    bar_box = box([outer_x + depth / 2, c[1], c[2]], [depth / 2, 0, 0] + half_long + half_short)
    posts = []
    for sgn in (-1, 1):
        pc = c + sgn * la * (length / 2 - bar / 2)
        half = [standoff / 2, 0, 0] + np.abs(la) * bar / 2 + half_short
        posts.append(box([c[0] - standoff / 2, pc[1], pc[2]], half))
    bbox = gapartnet_corners([c[0] - standoff / 2, c[1], c[2]], la, _OUT, length, standoff, bar)
    return [bar_box, *posts], bbox


def edge_pull(edge, long_axis, toward_edge, length, standoff, plate, drop):
    """An edge pull: a J-profile fixed along a part's edge. ``edge`` is the middle of the edge on the face (x = the
    face), ``toward_edge`` the in-face unit direction from the part's inside to that edge. A lip ``plate`` thick runs
    ``standoff`` out of the face along the edge, a flange ``drop`` long turns back from its outer end, and a back
    plate on the face closes the profile: the fingers hook the slot between flange and face from the part's side,
    as on a real tab pull. Returns the three boxes and the GAPartNet bbox (a line handle: the whole profile)."""
    c, la, e = (np.asarray(v, float) for v in (edge, long_axis, toward_edge))
    fx, half_long = c[0], np.abs(la) * length / 2
    lip = box(c + e * (-plate / 2) + [-standoff / 2, 0, 0], [standoff / 2, 0, 0] + half_long + np.abs(e) * plate / 2)
    hook = c - e * (plate + drop / 2)  # the in-face centre of the flange and the back plate
    flange = box([fx - standoff + plate / 2, hook[1], hook[2]], [plate / 2, 0, 0] + half_long + np.abs(e) * drop / 2)
    back = box([fx - plate / 2, hook[1], hook[2]], [plate / 2, 0, 0] + half_long + np.abs(e) * drop / 2)
    width = plate + drop
    centre = c - e * width / 2 + [-standoff / 2, 0, 0]
    # gapartnet_corners' short axis (normal x long) is symmetric about the centre: only the extents matter
    bbox = gapartnet_corners(centre, la, _OUT, length, standoff, width)
    return [lip, flange, back], bbox


def knob(centre, standoff, radius, back: float | None = None, rose: bool = False, cap=0.02):
    """A round knob: a stem ``standoff`` out along -x from the surface at ``centre[0]`` and a square cap of half
    size ``radius`` (box meshes). ``rose`` adds a thin base plate on the face (a cabinet knob: three boxes, as a bar
    handle). With ``back`` (the x of the panel's other face) a second knob mirrors it there, and the one bbox spans
    both knobs and the panel, as GAPartNet annotates a door's double-sided knob. Returns the boxes and the bbox."""
    c = np.asarray(centre, float)
    stem = box([c[0] - (standoff - cap) / 2, c[1], c[2]], [(standoff - cap) / 2, radius / 3, radius / 3])
    cap_box = box([c[0] - standoff + cap / 2, c[1], c[2]], [cap / 2, radius, radius])
    boxes, lo, hi = [stem, cap_box], c[0] - standoff, c[0]
    if rose:  # thin and small: a 6 mm rose 0.7 radius wide had the fingertips behind the cap press into it (one
        # cabinet door of 40 failed the expert's gate on penetration), this one none of 31
        boxes.append(box([c[0] - 0.001, c[1], c[2]], [0.001, 0.5 * radius, 0.5 * radius]))
    if back is not None:
        mirror = c[0] + back  # x -> mirror - x maps the front face onto the back face
        boxes += [Box(np.array([mirror - b.hi[0], *b.lo[1:]]), np.array([mirror - b.lo[0], *b.hi[1:]]))
                  for b in list(boxes)]
        hi = back + standoff
    bbox = gapartnet_corners([(lo + hi) / 2, c[1], c[2]], [0, 0, 1.0], _OUT, 2 * radius, hi - lo, 2 * radius)
    return boxes, bbox
