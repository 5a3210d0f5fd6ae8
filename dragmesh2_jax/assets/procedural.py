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
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dragmesh2_jax.errors import DragMeshError

#: category -> (GAPartNet model category, kind of moving part)
CATEGORIES = {
    "drawer_cabinet": ("StorageFurniture", "drawer"),
    "door_cabinet": ("StorageFurniture", "side_door"),
    "microwave": ("Microwave", "side_door"),
    "dishwasher": ("Dishwasher", "bottom_door"),
    "oven": ("Oven", "bottom_door"),
    "refrigerator": ("Refrigerator", "side_door"),
    "trash_can": ("TrashCan", "lid"),
    "table": ("Table", "drawer"),
    "door": ("Door", "side_door"),  # a frame, a tall hinged panel and a round knob
    "double_knob_door": ("Door", "side_door"),  # the same with a knob on each face, annotated as one box
}
#: Categories built as a door in a frame (not a cabinet shell), with a round knob.
_DOORS = ("door", "double_knob_door")

# PartNet-Mobility's root joint: rpy (pi/2, 0, -pi/2) maps y-up mesh coordinates to the z-up base frame.
_ROOT_RPY = (np.pi / 2, 0.0, -np.pi / 2)
_R_ROOT = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # base <- mesh


@dataclass
class _Box:
    """An axis-aligned box in the z-up object frame."""

    lo: np.ndarray
    hi: np.ndarray

    def mesh_obj(self) -> str:
        """Wavefront OBJ of the box in the y-up mesh frame."""
        c = np.array([[x, y, z] for x in (self.lo[0], self.hi[0]) for y in (self.lo[1], self.hi[1])
                      for z in (self.lo[2], self.hi[2])])
        m = c @ _R_ROOT  # mesh = R^T base
        faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
        lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in m]
        for a, b, cc, d in faces:
            lines.append(f"f {a + 1} {b + 1} {cc + 1}")
            lines.append(f"f {a + 1} {cc + 1} {d + 1}")
        return "\n".join(lines) + "\n"


def _box(centre, half) -> _Box:
    c, h = np.asarray(centre, float), np.asarray(half, float)
    return _Box(c - h, c + h)


def gapartnet_corners(centre, long_axis, normal, length, depth, width) -> list[list[float]]:
    """8 corners in GAPartNet order: 0-3 outer face, c0-c4 = normal*depth, c0-c1 = long*length,
    c0-c3 = short*width with short = normal x long."""
    c, l, n = (np.asarray(v, float) for v in (centre, long_axis, normal))
    s = np.cross(n, l)
    outer = c + n * depth / 2
    top = [outer + l * length / 2 + s * width / 2, outer - l * length / 2 + s * width / 2,
           outer - l * length / 2 - s * width / 2, outer + l * length / 2 - s * width / 2]
    return [list(map(float, p)) for p in top + [p - n * depth for p in top]]


@dataclass
class _LinkSpec:
    name: str
    boxes: list[_Box]
    semantic: tuple[str, str]  # (joint word, part word) for semantics files
    category: str | None  # GAPartNet category, None for the body


def _handle(centre, long_axis, length, standoff, bar=0.025):
    """A line handle: a bar ``standoff`` out along -x from the surface at ``centre[0]``, plus two posts.
    Returns the boxes and the GAPartNet bbox of the whole handle."""
    c = np.asarray(centre, float)
    la = np.asarray(long_axis, float)
    outer_x = c[0] - standoff
    half_long = np.abs(la) * length / 2
    short = np.cross(np.array([-1.0, 0, 0]), la)
    half_short = np.abs(short) * bar / 2
    bar_box = _box([outer_x + bar / 2, c[1], c[2]], [bar / 2, 0, 0] + half_long + half_short)
    posts = []
    for sgn in (-1, 1):
        pc = c + sgn * la * (length / 2 - bar / 2)
        half = [standoff / 2, 0, 0] + np.abs(la) * bar / 2 + half_short
        posts.append(_box([c[0] - standoff / 2, pc[1], pc[2]], half))
    bbox_centre = [c[0] - standoff / 2, c[1], c[2]]
    bbox = gapartnet_corners(bbox_centre, la, [-1.0, 0, 0], length, standoff, bar)
    return [bar_box, *posts], bbox


def _knob(centre, standoff, radius, back: float | None = None, cap=0.02):
    """A round knob: a stem ``standoff`` out along -x from the surface at ``centre[0]`` and a square cap of half
    size ``radius`` (box meshes). With ``back`` (the x of the panel's other face) a second knob mirrors it there,
    and the one bbox spans both knobs and the panel, as GAPartNet annotates a door's double-sided knob.
    Returns the boxes and the GAPartNet bbox."""
    c = np.asarray(centre, float)
    stem = _box([c[0] - (standoff - cap) / 2, c[1], c[2]], [(standoff - cap) / 2, radius / 3, radius / 3])
    cap_box = _box([c[0] - standoff + cap / 2, c[1], c[2]], [cap / 2, radius, radius])
    boxes, lo, hi = [stem, cap_box], c[0] - standoff, c[0]
    if back is not None:
        mirror = c[0] + back  # x -> mirror - x maps the front face onto the back face
        boxes += [_Box(np.array([mirror - b.hi[0], *b.lo[1:]]), np.array([mirror - b.lo[0], *b.hi[1:]]))
                  for b in (stem, cap_box)]
        hi = back + standoff
    bbox = gapartnet_corners([(lo + hi) / 2, c[1], c[2]], [0, 0, 1.0], [-1.0, 0, 0], 2 * radius, hi - lo, 2 * radius)
    return boxes, bbox


def _frame(W, D, H, t) -> list[_Box]:
    """Door frame: two jambs and a head behind the panel (front at x = -D/2)."""
    return [_box([0, W / 2 - t / 2, 0], [D / 2, t / 2, H / 2]), _box([0, -W / 2 + t / 2, 0], [D / 2, t / 2, H / 2]),
            _box([0, 0, H / 2 - t / 2], [D / 2, W / 2, t / 2])]


def _shell(W, D, H, t, open_top=False) -> list[_Box]:
    """Cabinet body: back, two sides, top, bottom (front open). Front at x = -D/2."""
    boxes = [
        _box([D / 2 - t / 2, 0, 0], [t / 2, W / 2, H / 2]),
        _box([0, W / 2 - t / 2, 0], [D / 2, t / 2, H / 2]),
        _box([0, -W / 2 + t / 2, 0], [D / 2, t / 2, H / 2]),
        _box([0, 0, -H / 2 + t / 2], [D / 2, W / 2, t / 2]),
    ]
    if not open_top:
        boxes.append(_box([0, 0, H / 2 - t / 2], [D / 2, W / 2, t / 2]))
    return boxes


def make_object(category: str, seed: int, hinge_side: str | None = None) -> dict:
    """Geometry and annotations of one procedural object (object frame, unscaled)."""
    if category not in CATEGORIES:
        raise DragMeshError(f"unknown procedural category {category!r} (choose from {', '.join(CATEGORIES)})")
    model_cat, kind = CATEGORIES[category]
    rng = np.random.default_rng(seed)
    u = lambda a, b: float(rng.uniform(a, b))  # noqa: E731
    t = 0.03  # panel thickness
    dims = {
        "drawer_cabinet": (u(0.8, 1.2), u(0.6, 0.9), u(0.8, 1.3)),
        "table": (u(1.0, 1.4), u(0.7, 0.9), u(0.45, 0.6)),
        "door_cabinet": (u(0.7, 1.0), u(0.6, 0.8), u(1.0, 1.5)),
        "microwave": (u(0.9, 1.2), u(0.6, 0.8), u(0.55, 0.7)),
        "refrigerator": (u(0.7, 0.9), u(0.7, 0.8), u(1.6, 1.9)),
        "dishwasher": (u(0.8, 1.0), u(0.8, 0.9), u(1.0, 1.2)),
        "oven": (u(0.8, 1.0), u(0.8, 0.9), u(0.8, 1.0)),
        "trash_can": (u(0.6, 0.8), u(0.6, 0.8), u(0.9, 1.2)),
        "door": (u(0.8, 1.0), u(0.10, 0.15), u(1.9, 2.2)),
    }["door" if category in _DOORS else category]  # one draw per entry: a new entry would change every seed
    W, D, H = dims
    hinge_side = hinge_side or ("left" if rng.uniform() < 0.5 else "right")
    standoff, bar = u(0.06, 0.09), u(0.022, 0.03)
    links: list[_LinkSpec] = []
    joints: list[dict] = []
    parts: list[dict] = []
    body_boxes = _frame(W, D, H, t) if category in _DOORS else _shell(W, D, H, t, open_top=(kind == "lid"))
    body = _LinkSpec("link_body", body_boxes, ("heavy", "body"), None)

    if kind == "drawer":
        n = 1 if category == "table" else int(rng.integers(2, 5))
        gap = 0.01
        h_each = (H - 2 * t - (n + 1) * gap) / n
        z_top = H / 2 - t - gap
        if category == "table":  # a table top on four legs, one drawer under the top
            body.boxes = [_box([0, 0, H / 2 - t / 2], [D / 2, W / 2, t / 2])]
            body.boxes += [_box([sx * (D / 2 - 0.04), sy * (W / 2 - 0.04), -t / 2], [0.03, 0.03, H / 2 - t / 2])
                           for sx in (-1, 1) for sy in (-1, 1)]
            h_each = min(0.15, H * 0.3)
            z_top = H / 2 - t - gap
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
            name, hname = f"link_d{i}", f"link_h{i}"
            links.append(_LinkSpec(name, boxes, ("slider", "drawer"), "slider_drawer"))
            parts.append({"link": name, "category": "slider_drawer",
                          "bbox": gapartnet_corners([0, 0, zc], [0, 1.0, 0], [-1.0, 0, 0], W - 2 * t, D, h_each)})
            joints.append({"name": f"joint_d{i}", "type": "prismatic", "child": name, "parent": "link_body",
                           "pivot": [0, 0, 0], "axis": [-1.0, 0, 0], "limit": [0.0, round(0.8 * D, 4)]})
            hboxes, hbbox = _handle([-D / 2, 0, zc], [0, 1.0, 0], u(0.3, 0.6) * W, standoff, bar)
            links.append(_LinkSpec(hname, hboxes, ("fixed", "handle"), "line_fixed_handle"))
            parts.append({"link": hname, "category": "line_fixed_handle", "bbox": hbbox})
            joints.append({"name": f"joint_h{i}", "type": "fixed", "child": hname, "parent": name})
    elif kind in ("side_door", "bottom_door", "lid"):
        if kind == "side_door":
            sgn = 1.0 if hinge_side == "left" else -1.0  # hinge on +y (left, seen from the front) or -y
            pivot = [-D / 2, sgn * W / 2, 0.0]
            axis = [0, 0, -sgn]  # +q swings the free edge out to -x
            door = _box([-D / 2 + t / 2, 0, 0], [t / 2, W / 2, H / 2])
            h_centre, h_long, h_len = [-D / 2, -sgn * (W / 2 - 0.12 * W), 0.0], [0, 0, 1.0], u(0.25, 0.45) * H
            door_bbox = gapartnet_corners([-D / 2 + t / 2, 0, 0], [0, 0, 1.0], [-1.0, 0, 0], H, t, W)
            cat = "hinge_door"
        elif kind == "bottom_door":
            pivot, axis = [-D / 2, 0.0, -H / 2], [0, -1.0, 0]  # +q swings the top edge out and down
            door = _box([-D / 2 + t / 2, 0, 0], [t / 2, W / 2, H / 2])
            h_centre, h_long, h_len = [-D / 2, 0.0, H / 2 - 0.1 * H], [0, 1.0, 0], u(0.4, 0.7) * W
            door_bbox = gapartnet_corners([-D / 2 + t / 2, 0, 0], [0, 1.0, 0], [-1.0, 0, 0], W, t, H)
            cat = "hinge_door"
        else:  # lid hinged at the top back edge, opening upwards
            pivot, axis = [D / 2, 0.0, H / 2], [0, 1.0, 0]
            door = _box([0, 0, H / 2 + t / 2], [D / 2, W / 2, t / 2])
            h_centre, h_long, h_len = [-D / 2, 0.0, H / 2 + t / 2], [0, 1.0, 0], u(0.3, 0.5) * W
            door_bbox = gapartnet_corners([0, 0, H / 2 + t / 2], [0, 1.0, 0], [0, 0, 1.0], W, t, D)
            cat = "hinge_lid"
        links.append(_LinkSpec("link_door", [door], ("hinge", "door" if cat == "hinge_door" else "lid"), cat))
        parts.append({"link": "link_door", "category": cat, "bbox": door_bbox})
        joints.append({"name": "joint_door", "type": "revolute", "child": "link_door", "parent": "link_body",
                       "pivot": pivot, "axis": axis, "limit": [0.0, round(float(np.radians(u(95, 120))), 4)]})
        if category in _DOORS:  # a round knob near the free edge, at about a third of the height from the floor
            h_centre = [-D / 2, h_centre[1], -H / 6]
            back = -D / 2 + t if category == "double_knob_door" else None
            hboxes, hbbox = _knob(h_centre, standoff, u(0.03, 0.04), back)
            hcat = "round_fixed_handle"
        else:
            hboxes, hbbox = _handle(h_centre, h_long, h_len, standoff, bar)
            hcat = "line_fixed_handle"
        links.append(_LinkSpec("link_handle", hboxes, ("fixed", "handle"), hcat))
        parts.append({"link": "link_handle", "category": hcat, "bbox": hbbox})
        joints.append({"name": "joint_handle", "type": "fixed", "child": "link_handle", "parent": "link_door"})
    links.insert(0, body)
    return {"category": category, "model_cat": model_cat, "seed": seed, "dims": [W, D, H], "links": links,
            "joints": joints, "parts": parts, "hinge_side": hinge_side if kind == "side_door" else None}


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
        mob = []
        for j in spec["joints"]:
            if j["type"] == "fixed":
                continue
            mob.append({"id": len(mob), "parent": 0, "joint": "slider" if j["type"] == "prismatic" else "hinge",
                        "name": j["child"], "jointData": {
                            "axis": {"origin": list(np.asarray(j["pivot"], float) @ _R_ROOT),
                                     "direction": list(np.asarray(j["axis"], float) @ _R_ROOT)},
                            "limit": {"a": j["limit"][0], "b": j["limit"][1], "noLimit": False}}})
        (tmp / "mobility_v2.json").write_text(json.dumps(mob))
        meta = {"model_cat": spec["model_cat"], "anno_id": object_id, "procedural": True,
                "generator": {"category": spec["category"], "seed": spec["seed"], "dims_WDH": spec["dims"],
                              "hinge_side": spec["hinge_side"]}}
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
    """The procedural objects that ship with the package (the embedded default)."""
    return Path(__file__).resolve().parent.parent / "data" / "objects"


#: The packaged heavy drawer: a 2.7 kg part with a 0.25 m bar handle (``make_object("drawer_cabinet", 213)``), the
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
