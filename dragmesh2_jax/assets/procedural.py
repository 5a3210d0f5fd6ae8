"""Procedural articulated objects written as GAPartNet-format folders (box meshes), so they go through exactly
the same loader as real data: ``mobility_annotation_gapartnet.urdf`` (y-up meshes under the PartNet root
rotation), ``link_annotation_gapartnet.json`` (8-corner boxes, z-up base frame, GAPartNet corner order),
``mobility_v2.json``, ``semantics_gapartnet.txt`` and ``meta.json``.

Object frame (z-up, unscaled, as PartNet-Mobility's base frame): the front faces -x, width along y.
"""

from __future__ import annotations

import json
import shutil
import tempfile
import zlib
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from dragmesh2_jax.assets.procedural_handles import R_ROOT as _R_ROOT
from dragmesh2_jax.assets.procedural_handles import Box, edge_pull, gapartnet_corners, knob, line_handle
from dragmesh2_jax.assets.procedural_handles import box as _box
from dragmesh2_jax.errors import DragMeshError

#: category -> (GAPartNet model category, kind of moving part)
CATEGORIES = {
    "drawer_cabinet": ("StorageFurniture", "drawer"),
    "door_cabinet": ("StorageFurniture", "side_door"),
    "microwave": ("Microwave", "side_door"),
    "dishwasher": ("Dishwasher", "bottom_door"),
    "oven": ("Oven", "bottom_door"),
    "refrigerator": ("Refrigerator", "side_door"),  # a top freezer door and a main door; either is the target
    "trash_can": ("TrashCan", "lid"),
    "table": ("Table", "drawer"),
    "door": ("Door", "side_door"),  # a frame, a tall hinged panel and a round knob
    "double_knob_door": ("Door", "side_door"),  # the same with a knob on each face, annotated as one box
}
#: Categories built as a door in a frame (not a cabinet shell), with a round knob.
_DOORS = ("door", "double_knob_door")
#: Version of the generator's distributions (meta.json). 2: every quantity drawn from streams seeded by (category,
#: seed), and the handle, hinge, size and range distributions widened to hold the real objects (RESULTS.md §6c). A
#: (category, seed) of version 1 (the packaged objects) is another object under version 2.
PROCEDURAL_VERSION = 2

# PartNet-Mobility's root joint: rpy (pi/2, 0, -pi/2) maps y-up mesh coordinates to the z-up base frame.
_ROOT_RPY = (np.pi / 2, 0.0, -np.pi / 2)
_T = 0.03  # panel thickness (m, unscaled: the scene scales objects by 0.4)

#: (W, D, H) ranges (m, unscaled) per geometry family, wide enough to hold the real objects (unscaled: 45261's drawer
#: is 1.17 m wide and 1.09 m deep, 11712's refrigerator door 0.67 x 0.42 m, 45780's cabinet door 0.69 x 0.82 m):
#: drawer cabinets to 1.4 m wide and 1.2 m deep, cabinet doors and microwaves down to 0.45-0.55 m wide and 0.35-0.5 m
#: tall (doors of half a kilogram or less in the scene, as 11712's).
_DIMS = {
    "drawer_cabinet": ((0.7, 1.4), (0.6, 1.2), (0.8, 1.3)),
    "table": ((1.0, 1.4), (0.7, 0.9), (0.45, 0.6)),
    "door_cabinet": ((0.45, 1.0), (0.5, 0.8), (0.5, 1.5)),
    "microwave": ((0.55, 1.2), (0.5, 0.8), (0.35, 0.7)),
    "refrigerator": ((0.6, 0.9), (0.7, 0.8), (1.6, 1.9)),
    "dishwasher": ((0.8, 1.0), (0.8, 0.9), (1.0, 1.2)),
    "oven": ((0.8, 1.0), (0.8, 0.9), (0.8, 1.0)),
    "trash_can": ((0.6, 0.8), (0.6, 0.8), (0.9, 1.2)),
    "door": ((0.8, 1.0), (0.10, 0.15), (1.9, 2.2)),
}
_CABINET_HANDLES = {"bar": 0.6, "edge": 0.2, "knob": 0.2}
_APPLIANCE_HANDLES = {"bar": 0.75, "edge": 0.25}
#: Handle kinds and their odds per category. A lid's front edge is one panel thick: no room for an edge pull.
HANDLE_KINDS = {
    "drawer_cabinet": _CABINET_HANDLES, "door_cabinet": _CABINET_HANDLES, "table": _CABINET_HANDLES,
    "microwave": _APPLIANCE_HANDLES, "refrigerator": _APPLIANCE_HANDLES, "dishwasher": _APPLIANCE_HANDLES,
    "oven": _APPLIANCE_HANDLES, "trash_can": {"bar": 1.0}, "door": {"knob": 1.0}, "double_knob_door": {"knob": 1.0},
}
#: Handle length bounds (m, unscaled): 0.06-0.42 m at scale 0.4, the real bars' 0.074-0.41 m and a margin.
_HANDLE_LENGTH = (0.15, 1.05)
#: Revolute ranges (deg): the real doors open 90-94 deg, the generator's doors before version 2 95-120 deg.
_DOOR_RANGE_DEG = (85.0, 120.0)
#: Drawer travel as a fraction of the depth (45261 slides 0.80 of its depth, 45661 0.87 of it; the generator's drawers
#: before version 2 0.8).
_DRAWER_TRAVEL = (0.65, 0.9)


def _streams(category: str, seed: int) -> dict[str, np.random.Generator]:
    """One object's random streams, seeded by (geometry family, seed), so each category draws its own hinge side,
    standoff and ranges; one per group of quantities, so a draw added to one group leaves the others' values."""
    if seed < 0:
        raise DragMeshError(f"a procedural seed must be >= 0, got {seed}")
    family = "door" if category in _DOORS else category  # a door and its double-knob twin share the geometry
    seq = np.random.SeedSequence([seed, zlib.crc32(family.encode())])
    return dict(zip(("dims", "handle", "joint", "hinge"), map(np.random.default_rng, seq.spawn(4)), strict=True))


@dataclass(frozen=True)
class _Style:
    """One object's handle look: its kind and cross-section (every handle of the object shares it)."""

    kind: str  # "bar", "edge" or "knob"
    standoff: float  # how far the handle stands out of the face (0.012-0.036 m at scale 0.4)
    bar: float  # bar width across the face (6-12 mm at scale 0.4)
    depth: float  # bar depth along the normal: at most half the standoff, so the fingers keep a gap behind it
    plate: float  # an edge pull's sheet thickness
    drop: float  # an edge pull's flange length (the slot the fingers hook)
    radius: float  # a knob's cap half size
    rose: bool  # a cabinet knob's base plate (three boxes, as a bar)
    length: float | None = None  # a twin's handle length (m), kept as measured; None: drawn per handle


@dataclass(frozen=True)
class Twin:
    """What a procedural twin keeps of a measured object (m, unscaled): its body's width, depth and height (its part's
    size and mass follow), its handles' kind and length; the rest is its seed's, as any object's (``objects twin``)."""

    dims: tuple[float, float, float]
    handle_length: float
    handle_kind: str = "bar"


def _style(category: str, rng: np.random.Generator) -> _Style:
    odds = HANDLE_KINDS[category]
    # a fixed number of draws whatever the kind, so the kind does not shift the other values
    pick, standoff, bar = rng.uniform(), rng.uniform(0.03, 0.09), rng.uniform(0.015, 0.03)
    plate, drop, radius = rng.uniform(0.008, 0.012), rng.uniform(0.02, 0.035), rng.uniform(0.03, 0.04)
    kind = list(odds)[int(np.searchsorted(np.cumsum(list(odds.values())), pick * sum(odds.values())))]
    # (the remaps keep the standoff uniform over a narrower range)
    if kind == "knob":
        standoff = 0.05 + (standoff - 0.03) * 2 / 3  # 0.05-0.09: a knob needs a neck behind its cap
    elif kind == "edge":
        # 0.045-0.09 out and a 25-40 mm flange: room for the fingers in the slot behind the flange (measured on 46 edge
        # pulls: the expert's trajectory passed the gate gripping the pull in 41 with 0.03-0.09 m and 20-35 mm, 43 so)
        standoff, drop = 0.045 + (standoff - 0.03) * 0.75, drop + 0.005
    elif CATEGORIES[category][1] == "lid":
        # 0.06-0.09 (no real lid to match): measured, bars 0.034-0.055 m proud on a lid's thin front edge failed the
        # gate in 2 of 30 and 4 of 40 lids (reaching behind them the hand leaves its joint limits), none of 40 from 0.06
        standoff = 0.06 + (standoff - 0.03) / 2
    return _Style(kind, float(standoff), float(bar), float(min(bar, standoff / 2)), float(plate), float(drop),
                  float(radius), category not in _DOORS)


def _handle(style: _Style, centre, long_axis, length: float, edge, toward_edge, back: float | None = None):
    """The object's kind of handle: a bar or knob at ``centre``, or an edge pull along the edge through ``edge``.
    Returns the boxes, the GAPartNet bbox and the GAPartNet category."""
    if style.kind == "knob":
        boxes, bbox = knob(centre, style.standoff, style.radius, back, rose=style.rose)
        return boxes, bbox, "round_fixed_handle"
    length = length if style.length is None else style.length
    if style.kind == "edge":
        boxes, bbox = edge_pull(edge, long_axis, toward_edge, length, style.standoff, style.plate, style.drop)
    else:
        boxes, bbox = line_handle(centre, long_axis, length, style.standoff, style.bar, style.depth)
    return boxes, bbox, "line_fixed_handle"


def _length(fraction: float, span: float) -> float:
    """A handle ``fraction`` of ``span`` long, within the length bounds and 0.95 of the span."""
    return float(np.clip(fraction * span, _HANDLE_LENGTH[0], min(_HANDLE_LENGTH[1], 0.95 * span)))


def _frame(W, D, H, t) -> list[Box]:
    """Door frame: two jambs and a head behind the panel (front at x = -D/2)."""
    return [_box([0, W / 2 - t / 2, 0], [D / 2, t / 2, H / 2]), _box([0, -W / 2 + t / 2, 0], [D / 2, t / 2, H / 2]),
            _box([0, 0, H / 2 - t / 2], [D / 2, W / 2, t / 2])]


def _shell(W, D, H, t, open_top=False) -> list[Box]:
    """Cabinet body: back, two sides, bottom and (unless ``open_top``) top; the front open, at x = -D/2."""
    return [_box([D / 2 - t / 2, 0, 0], [t / 2, W / 2, H / 2]), _box([0, W / 2 - t / 2, 0], [D / 2, t / 2, H / 2]),
            _box([0, -W / 2 + t / 2, 0], [D / 2, t / 2, H / 2]), _box([0, 0, -H / 2 + t / 2], [D / 2, W / 2, t / 2])
            ] + ([] if open_top else [_box([0, 0, H / 2 - t / 2], [D / 2, W / 2, t / 2])])


@dataclass
class _LinkSpec:
    name: str
    boxes: list[Box]
    semantic: tuple[str, str]  # (joint word, part word) for semantics files
    category: str | None  # GAPartNet category, None for the body


class _Parts:
    """The links, joints and GAPartNet parts of an object's moving parts, in annotation order (the loader's target
    is the first drawer, else the first door: the order of ``parts``)."""

    def __init__(self):
        self.links: list[_LinkSpec] = []
        self.joints: list[dict] = []
        self.parts: list[dict] = []

    def add(self, name: str, boxes, semantic, category: str, bbox, joint: dict) -> None:
        self.links.append(_LinkSpec(name, list(boxes), semantic, category))
        self.parts.append({"link": name, "category": category, "bbox": bbox})
        self.joints.append({"name": f"joint_{name.removeprefix('link_')}", "child": name, **joint})

    def add_handle(self, name: str, parent: str, handle) -> None:
        boxes, bbox, category = handle
        self.add(name, boxes, ("fixed", "handle"), category, bbox, {"type": "fixed", "parent": parent})


def _drawers(p: _Parts, category, W, D, H, body, style, rng, travel: float) -> None:
    t, gap = _T, 0.01
    n = 1 if category == "table" else int(rng["dims"].integers(2, 5))
    h_each = (H - 2 * t - (n + 1) * gap) / n
    z_top = H / 2 - t - gap
    if category == "table":  # a table top on four legs, one drawer under the top
        body.boxes = [_box([0, 0, H / 2 - t / 2], [D / 2, W / 2, t / 2])]
        body.boxes += [_box([sx * (D / 2 - 0.04), sy * (W / 2 - 0.04), -t / 2], [0.03, 0.03, H / 2 - t / 2])
                       for sx in (-1, 1) for sy in (-1, 1)]
        h_each = min(0.15, H * 0.3)
    for i in range(n):
        zc = z_top - h_each / 2 - i * (h_each + gap)
        w_in, d_in = W - 2 * t - 2 * gap, D - 2 * t
        boxes = [
            _box([-D / 2 + t / 2, 0, zc], [t / 2, W / 2 - t - gap / 2, h_each / 2]),  # front panel
            _box([-D / 2 + t + d_in / 2, 0, zc - h_each / 2 + t / 2], [d_in / 2, w_in / 2, t / 2]),  # bottom
            _box([-D / 2 + t + d_in / 2, w_in / 2 - t / 2, zc], [d_in / 2, t / 2, h_each / 2 - gap]),
            _box([-D / 2 + t + d_in / 2, -w_in / 2 + t / 2, zc], [d_in / 2, t / 2, h_each / 2 - gap]),
            _box([D / 2 - t - t / 2, 0, zc], [t / 2, w_in / 2, h_each / 2 - gap]),  # back
        ]
        bbox = gapartnet_corners([0, 0, zc], [0, 1.0, 0], [-1.0, 0, 0], W - 2 * t, D, h_each)
        p.add(f"link_d{i}", boxes, ("slider", "drawer"), "slider_drawer", bbox,
              {"type": "prismatic", "parent": "link_body", "pivot": [0, 0, 0], "axis": [-1.0, 0, 0],
               "limit": [0.0, round(travel * D, 4)]})
        # up to nearly the drawer's width: both real drawers' bars span 0.88 of it (the old 0.3-0.6 never did)
        fraction = float(rng["handle"].uniform(0.25, 0.95))
        p.add_handle(f"link_h{i}", f"link_d{i}", _handle(
            style, [-D / 2, 0, zc], [0, 1.0, 0], _length(fraction, W - 2 * t), [-D / 2, 0, zc + h_each / 2],
            [0, 0, 1.0]))


def _side_door(p: _Parts, suffix: str, category, W, D, zl, zh, sgn, style, rng, limit: float) -> None:
    """A door hinged on a vertical edge (+y for ``sgn`` 1: left, seen from the front), spanning z in [zl, zh]; its
    handle 5-20 % of the width from the free edge (a knob at least its cap and 2 cm in)."""
    t, hd, zc = _T, zh - zl, (zl + zh) / 2
    door = _box([-D / 2 + t / 2, 0, zc], [t / 2, W / 2, hd / 2])
    bbox = gapartnet_corners([-D / 2 + t / 2, 0, zc], [0, 0, 1.0], [-1.0, 0, 0], hd, t, W)
    name = f"link_door{suffix}"
    p.add(name, [door], ("hinge", "door"), "hinge_door", bbox,
          {"type": "revolute", "parent": "link_body", "pivot": [-D / 2, sgn * W / 2, zc], "axis": [0, 0, -sgn],
           "limit": [0.0, limit]})  # +q swings the free edge out to -x
    fraction, inset = rng["handle"].uniform(0.15, 0.6), rng["handle"].uniform(0.05, 0.2) * W
    inset = max(inset, style.radius + 0.02) if style.kind == "knob" else max(inset, style.bar / 2 + 0.01)
    z = zl + hd / 3 if category in _DOORS else zc  # a door's knob at a third of its height from the floor
    back = -D / 2 + t if category == "double_knob_door" else None
    p.add_handle(f"link_handle{suffix}", name, _handle(
        style, [-D / 2, -sgn * (W / 2 - inset), z], [0, 0, 1.0], _length(fraction, hd), [-D / 2, -sgn * W / 2, zc],
        [0, -sgn, 0], back))


def make_object(category: str, seed: int, hinge_side: str | None = None, twin: Twin | None = None) -> dict:
    """Geometry and annotations of one procedural object (object frame, unscaled), reproducible from
    ``(category, seed)``; ``hinge_side`` ("left"/"right", seen from the front) overrides a side door's draw and
    nothing else, ``twin`` the size and the handles (every draw still made, so the rest is the seed's)."""
    if category not in CATEGORIES:
        raise DragMeshError(f"unknown procedural category {category!r} (choose from {', '.join(CATEGORIES)})")
    model_cat, kind = CATEGORIES[category]
    rng = _streams(category, seed)
    t = _T
    drawn = [float(rng["dims"].uniform(a, b)) for a, b in _DIMS["door" if category in _DOORS else category]]
    W, D, H = drawn if twin is None else map(float, twin.dims)
    hinge_side = hinge_side or ("left" if rng["hinge"].uniform() < 0.5 else "right")  # the hinge stream's only draw
    style = _style(category, rng["handle"])
    if twin is not None:
        if twin.handle_kind not in HANDLE_KINDS[category] or min(*twin.dims, twin.handle_length) <= 0:
            raise DragMeshError(f"a {category} twin needs sizes > 0 and a handle: {', '.join(HANDLE_KINDS[category])}")
        style = replace(style, kind=twin.handle_kind, length=float(twin.handle_length))
    travel = float(rng["joint"].uniform(*_DRAWER_TRAVEL))
    limits = [round(float(np.radians(rng["joint"].uniform(*_DOOR_RANGE_DEG))), 4) for _ in range(2)]
    body_boxes = _frame(W, D, H, t) if category in _DOORS else _shell(W, D, H, t, open_top=(kind == "lid"))
    body = _LinkSpec("link_body", body_boxes, ("heavy", "body"), None)
    p, variant = _Parts(), None
    if kind == "drawer":
        _drawers(p, category, W, D, H, body, style, rng, travel)
    elif kind == "side_door":
        sgn = 1.0 if hinge_side == "left" else -1.0
        if category == "refrigerator":
            # a top freezer door 18-40 % of the height over the main door; the target (annotated first) is either,
            # so the mix holds short wide doors of about half a kilogram (11712's target) beside tall ones
            split = H / 2 - float(rng["dims"].uniform(0.18, 0.4)) * H
            freezer = bool(rng["dims"].uniform() < 0.5)
            variant = "freezer door" if freezer else "main door"
            body.boxes.append(_box([0, 0, split], [D / 2 - t, W / 2 - t, t / 2]))  # the divider shelf, behind the doors
            spans = [(split + 0.005, H / 2), (-H / 2, split - 0.005)]
            for (zl, zh), suffix, limit in zip(spans if freezer else spans[::-1], ("", "1"), limits, strict=True):
                _side_door(p, suffix, category, W, D, zl, zh, sgn, style, rng, limit)
        else:
            _side_door(p, "", category, W, D, -H / 2, H / 2, sgn, style, rng, limits[0])
    elif kind == "bottom_door":
        door = _box([-D / 2 + t / 2, 0, 0], [t / 2, W / 2, H / 2])
        bbox = gapartnet_corners([-D / 2 + t / 2, 0, 0], [0, 1.0, 0], [-1.0, 0, 0], W, t, H)
        p.add("link_door", [door], ("hinge", "door"), "hinge_door", bbox,
              {"type": "revolute", "parent": "link_body", "pivot": [-D / 2, 0.0, -H / 2], "axis": [0, -1.0, 0],
               "limit": [0.0, limits[0]]})  # +q swings the top edge out and down
        fraction, inset = rng["handle"].uniform(0.3, 0.9), rng["handle"].uniform(0.05, 0.2) * H
        inset = max(inset, style.bar / 2 + 0.01)
        p.add_handle("link_handle", "link_door", _handle(
            style, [-D / 2, 0.0, H / 2 - inset], [0, 1.0, 0], _length(fraction, W), [-D / 2, 0.0, H / 2],
            [0, 0, 1.0]))
    else:  # lid hinged at the top back edge, opening upwards; a bar on its front edge
        lid = _box([0, 0, H / 2 + t / 2], [D / 2, W / 2, t / 2])
        bbox = gapartnet_corners([0, 0, H / 2 + t / 2], [0, 1.0, 0], [0, 0, 1.0], W, t, D)
        p.add("link_door", [lid], ("hinge", "lid"), "hinge_lid", bbox,
              {"type": "revolute", "parent": "link_body", "pivot": [D / 2, 0.0, H / 2], "axis": [0, 1.0, 0],
               "limit": [0.0, limits[0]]})
        fraction = rng["handle"].uniform(0.3, 0.8)
        p.add_handle("link_handle", "link_door", _handle(
            style, [-D / 2, 0.0, H / 2 + t / 2], [0, 1.0, 0], _length(fraction, W), None, None))
    return {"category": category, "model_cat": model_cat, "seed": seed, "dims": [W, D, H], "links": [body, *p.links],
            "joints": p.joints, "parts": p.parts, "hinge_side": hinge_side if kind == "side_door" else None,
            "handle_kind": style.kind, "variant": variant, "twin": None if twin is None else asdict(twin)}


def _fmt(v) -> str:
    return " ".join(f"{float(x):.6f}" for x in v)


def write_object(spec: dict, folder: str | Path, object_id: str) -> Path:
    """Write ``spec`` as a GAPartNet-format folder (atomically: built in a temp folder, then renamed)."""
    folder = Path(folder)
    if folder.exists():
        raise DragMeshError(f"{folder}: already exists (refusing to overwrite)")
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}.", dir=folder.parent))
    try:
        (tmp / "textured_objs").mkdir()
        pivot_of = {j["child"]: np.asarray(j.get("pivot", [0, 0, 0]), float) for j in spec["joints"]}
        parent_of = {j["child"]: j["parent"] for j in spec["joints"]}

        def frame_offset(link: str) -> np.ndarray:
            """Position (mesh frame) of a link's frame: the pivot of its nearest movable ancestor joint."""
            while link in parent_of:
                if any(j["child"] == link and j["type"] != "fixed" for j in spec["joints"]):
                    return pivot_of[link] @ _R_ROOT
                link = parent_of[link]
            return np.zeros(3)

        urdf = [f'<?xml version="1.0" ?>\n<robot name="procedural_{object_id}">', '\t<link name="base"/>']
        k = 0
        for link in spec["links"]:
            off = frame_offset(link.name)
            urdf.append(f'\t<link name="{link.name}">')
            for box in link.boxes:
                fn = f"textured_objs/original-{k}.obj"
                (tmp / fn).write_text(box.mesh_obj())
                k += 1
                for kind in ("visual", "collision"):
                    urdf.append(f'\t\t<{kind}>\n\t\t\t<origin xyz="{_fmt(-off)}"/>\n\t\t\t<geometry>\n'
                                f'\t\t\t\t<mesh filename="{fn}"/>\n\t\t\t</geometry>\n\t\t</{kind}>')
            urdf.append("\t</link>")
        for j in spec["joints"]:
            off = frame_offset(j["child"]) - frame_offset(j["parent"])
            lines = [f'\t<joint name="{j["name"]}" type="{j["type"]}">', f'\t\t<origin xyz="{_fmt(off)}"/>']
            if j["type"] != "fixed":
                lines.append(f'\t\t<axis xyz="{_fmt(np.asarray(j["axis"], float) @ _R_ROOT)}"/>')
            lines += [f'\t\t<child link="{j["child"]}"/>', f'\t\t<parent link="{j["parent"]}"/>']
            if j["type"] != "fixed":
                lines.append(f'\t\t<limit lower="{j["limit"][0]}" upper="{j["limit"][1]}"/>')
            urdf += lines + ["\t</joint>"]
        urdf.append(f'\t<joint name="joint_root" type="fixed">\n\t\t<origin rpy="{_fmt(_ROOT_RPY)}" xyz="0 0 0"/>\n'
                    f'\t\t<child link="link_body"/>\n\t\t<parent link="base"/>\n\t</joint>')
        urdf.append("</robot>\n")
        (tmp / "mobility_annotation_gapartnet.urdf").write_text("\n".join(urdf))

        ann = [{"link_name": p["link"], "is_gapart": True, "category": p["category"], "bbox": p["bbox"]}
               for p in spec["parts"]]
        ann.append({"link_name": "link_body", "is_gapart": False, "category": "", "bbox": []})
        (tmp / "link_annotation_gapartnet.json").write_text(json.dumps(ann, indent=1))
        sem = [f"{lk.name} {lk.semantic[0]} {lk.semantic[1]}" for lk in spec["links"]]
        (tmp / "semantics_gapartnet.txt").write_text("\n".join(sem) + "\n")
        mob: list[dict] = []
        for j in (j for j in spec["joints"] if j["type"] != "fixed"):
            mob.append({"id": len(mob), "parent": 0, "joint": "slider" if j["type"] == "prismatic" else "hinge",
                        "name": j["child"], "jointData": {
                            "axis": {"origin": list(np.asarray(j["pivot"], float) @ _R_ROOT),
                                     "direction": list(np.asarray(j["axis"], float) @ _R_ROOT)},
                            "limit": {"a": j["limit"][0], "b": j["limit"][1], "noLimit": False}}})
        (tmp / "mobility_v2.json").write_text(json.dumps(mob))
        meta = {"model_cat": spec["model_cat"], "anno_id": object_id, "procedural": True,
                "generator": {"version": PROCEDURAL_VERSION, "category": spec["category"], "seed": spec["seed"],
                              "dims_WDH": spec["dims"], "hinge_side": spec["hinge_side"],
                              "handle_kind": spec["handle_kind"], "variant": spec["variant"],
                              **({"twin": spec["twin"]} if spec["twin"] else {})}}
        (tmp / "meta.json").write_text(json.dumps(meta, indent=1))
        tmp.rename(folder)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return folder


def synthesize(category: str, count: int, seed: int, out: str | Path) -> list[Path]:
    """Write ``count`` objects of ``category`` (seeds ``seed .. seed+count-1``) under ``out``; existing ones
    are kept (so the call is resumable)."""
    if count < 1:
        raise DragMeshError(f"--count must be at least 1, got {count}")
    out = Path(out)
    paths = []
    for i in range(count):
        s = seed + i
        folder = out / f"{category}_{s:04d}"
        if not folder.exists():
            write_object(make_object(category, s), folder, object_id=f"{category}_{s:04d}")
        paths.append(folder)
    return paths


#: Paper Table 1: trajectories per GAPartNet category in the authors' dataset (277 in all).
PAPER_TABLE1 = {"StorageFurniture": 256, "TrashCan": 7, "Dishwasher": 5, "Refrigerator": 4, "Oven": 3,
                "Microwave": 1, "Table": 1}
#: Generator categories standing for each GAPartNet category of Table 1 (StorageFurniture: drawers and doors,
#: alternately).
TABLE1_CATEGORIES = {"StorageFurniture": ("drawer_cabinet", "door_cabinet"), "TrashCan": ("trash_can",),
                     "Dishwasher": ("dishwasher",), "Refrigerator": ("refrigerator",), "Oven": ("oven",),
                     "Microwave": ("microwave",), "Table": ("table",)}


def table1_mix(n: int) -> dict[str, int]:
    """Objects per generator category for ``n`` objects in the paper's Table 1 proportions (largest remainder;
    ``n = 277`` gives exactly the paper's counts)."""
    if n < 1:
        raise DragMeshError(f"the number of procedural objects must be >= 1, got {n}")
    total = sum(PAPER_TABLE1.values())
    share = {c: n * k / total for c, k in PAPER_TABLE1.items()}
    counts = {c: int(s) for c, s in share.items()}
    for c in sorted(share, key=lambda c: counts[c] - share[c])[: n - sum(counts.values())]:
        counts[c] += 1
    mix: dict[str, int] = {}
    for gap_cat, k in counts.items():
        cats = TABLE1_CATEGORIES[gap_cat]
        for i, c in enumerate(cats):
            mix[c] = mix.get(c, 0) + k // len(cats) + (i < k % len(cats))
    return {c: k for c, k in mix.items() if k}


def synthesize_table1(n: int, seed: int, out: str | Path) -> list[Path]:
    """``n`` procedural objects in the paper's Table 1 mix under ``out`` (resumable, as ``synthesize``)."""
    return [p for c, k in table1_mix(n).items() for p in synthesize(c, k, seed, out)]


#: The generalist's procedural mix: every category, doors as many as drawers (the real benchmark's parts
#: are doors as often as drawers), objects per category; the last of each category is held aside to select the
#: generalist's checkpoint on (``held_aside_by_category``), the others are trained on.
GENERALIST_MIX = {"drawer_cabinet": 10, "door_cabinet": 10, "microwave": 5, "refrigerator": 5, "dishwasher": 4,
                  "oven": 4, "trash_can": 3, "table": 3, "door": 3, "double_knob_door": 3}
#: The generalist's objects start at this seed (the packaged objects use seeds 0 and 213, reproduce's from 1000).
GENERALIST_SEED = 2000


def synthesize_mix(mix: dict[str, int], seed: int, out: str | Path) -> list[Path]:
    """``synthesize`` for each category of ``mix`` with its count (resumable)."""
    return [p for c, k in mix.items() for p in synthesize(c, k, seed, out)]


def category_of(folder: str | Path) -> str:
    """A procedural object's category, from its folder name (``door_cabinet_2003``)."""
    return Path(folder).name.rsplit("_", 1)[0]


def held_aside_by_category(objects: list, trajectories: list) -> tuple[list, list, int]:
    """``objects`` (procedural folders) and their trajectories reordered so that the last of each category comes
    last: (objects, trajectories, how many are held aside), a run's ``holdout`` drawn across every category."""
    last = {category_of(o): i for i, o in enumerate(objects)}
    held = sorted(last.values())
    order = [i for i in range(len(objects)) if i not in set(held)] + held
    return [objects[i] for i in order], [trajectories[i] for i in order], len(held)


def synthesize_categories(category: str, count: int, seed: int, out: str | Path) -> list[Path]:
    """``synthesize`` for one category, or for every category with ``category="all"``."""
    cats = list(CATEGORIES) if category == "all" else [category]
    if not set(cats) <= set(CATEGORIES):
        raise DragMeshError(f"unknown category {category!r} (choose from all, {', '.join(CATEGORIES)})")
    return [p for c in cats for p in synthesize(c, count, seed, out)]


def default_objects() -> list[Path]:
    """The packaged procedural objects (folders)."""
    return sorted(p for p in default_objects_dir().iterdir() if p.is_dir())


def default_objects_dir() -> Path:
    """The procedural objects that ship with the package (the embedded default): stored folders built by version 1
    of the generator (``meta.json`` records no version); ``make_object`` no longer builds them, and nothing rebuilds
    them."""
    return Path(__file__).resolve().parent.parent / "data" / "objects"


#: The packaged heavy drawer: a 2.7 kg part with a 0.25 m bar handle (version 1's drawer_cabinet seed 213), the
#: traits of the real drawer no learned method opened once the generator kept a fingertip grasp (RESULTS.md, the
#: drawer regression). A tuning object of every recipe, and the collapse check of the tests.
HEAVY_DRAWER = "drawer_cabinet_0213"


def packaged_object(name: str) -> Path:
    """A packaged procedural object folder by name (``default_objects``)."""
    path = default_objects_dir() / name
    if not path.is_dir():
        raise DragMeshError(f"{path}: the packaged object is missing (reinstall dragmesh2-jax)")
    return path


def default_object() -> Path:
    """The built-in default object: a procedural drawer cabinet."""
    return packaged_object("drawer_cabinet_0000")
