"""Coverage of real objects by the procedural ones (issue 36): per object, the quantities the task sees of its target
part (handle type, orientation and size, hinge side and radius, part size and mass, joint type and range, category),
for two procedural mixes (the paper's Table 1 mix, and the same number spread over every generator category) beside
each real object.

    python experiments/coverage.py --procedural 64 --seed 1000 --real ../shared/gapartnet/45261 ... \
        --out results/coverage

Everything is in the world frame of the task: the object scaled by the scene's scale (0.4), z up, at the closed
configuration; the target part, its joint and the handle frame are the loader's (paper Appendix B), the part mass is
the scene's thin-shell estimate. Writes ``coverage.json`` (one row per object), ``coverage.md`` (per quantity: each
mix's min, quartiles and max, each real object's value and whether each mix's range holds it) and ``coverage.png``
(a histogram per quantity, each real object a labelled vertical line).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from dragmesh2_jax.assets.gapartnet import GAPartNetObject, load_gapartnet
from dragmesh2_jax.assets.procedural import CATEGORIES, synthesize, synthesize_table1
from dragmesh2_jax.assets.target import half_thickness
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.io import atomic_write_figure, atomic_write_json, atomic_write_text
from dragmesh2_jax.scene import SceneConfig, build_scene

#: Categorical quantities: key -> title.
CATEGORICAL = {
    "category": "GAPartNet category",
    "joint_type": "joint type",
    "handle_type": "handle type",
    "hinge_side": "hinge side, seen from the handle (revolute)",
}
#: Numeric quantities: key -> title (with unit). ``None`` in a row where one does not apply.
NUMERIC = {
    "handle_tilt_deg": "bar long axis above horizontal [deg]",
    "handle_length_m": "handle length [m]",
    "handle_width_m": "handle width (short side) [m]",
    "handle_thickness_m": "handle thickness along its normal [m]",
    "handle_protrusion_m": "handle protrusion out of the part [m]",
    "hinge_radius_m": "handle offset from the hinge axis [m]",
    "part_width_m": "part front-face width [m]",
    "part_height_m": "part front-face height [m]",
    "part_mass_kg": "part mass (scene estimate) [kg]",
    "joint_range_m": "prismatic joint range [m]",
    "joint_range_rad": "revolute joint range [rad]",
}
MIXES = {"table1": "Table 1 mix", "all": "all categories"}
BAR_TILT_DEG = 30.0  # a bar within this of horizontal is horizontal, within this of vertical is vertical
KNOB_ASPECT = 1.5  # a handle whose length is at most this times its width is a knob


def category_mix(n: int) -> dict[str, int]:
    """``n`` objects spread as evenly as the count allows over every generator category (the first ones get the
    remainder)."""
    k, extra = divmod(n, len(CATEGORIES))
    counts = {c: k + (i < extra) for i, c in enumerate(CATEGORIES)}
    return {c: m for c, m in counts.items() if m}


def hinge_side(offset: np.ndarray, normal: np.ndarray) -> str:
    """Where a hinge lies from the handle (``offset``: handle centre to the hinge axis, perpendicular to it), seen by
    someone in front of the handle: left, right, top, bottom, or behind (a lid hinged at its far edge)."""
    up_ref = np.array([0.0, 0.0, 1.0]) if abs(normal[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    right = np.cross(up_ref, normal)
    right /= np.linalg.norm(right)
    up = np.cross(normal, right)
    sides = {"right": right, "left": -right, "top": up, "bottom": -up, "behind": -normal}
    return max(sides, key=lambda s: float(offset @ sides[s]))


def quantities(obj: GAPartNetObject, scale: float, mass: float) -> dict:
    """The coverage quantities of ``obj``'s target (world frame: lengths times ``scale``)."""
    t = obj.target
    h, part, joint = t.handle, t.part, t.joint
    handle_cat = next((p.category for p in obj.parts if p.link == h.link and p.is_handle), None)
    tilt = float(np.degrees(np.arcsin(min(1.0, abs(h.long_axis[2])))))
    if h.source == "front_face":
        kind = "none (front face)"
    elif "round" in (handle_cat or "") or h.length <= KNOB_ASPECT * h.width:
        kind = "knob"
    else:
        kind = ("horizontal bar" if tilt <= BAR_TILT_DEG else "vertical bar" if tilt >= 90 - BAR_TILT_DEG
                else "oblique bar")
    is_bar = kind.endswith("bar")
    protrusion = float(((h.corners() - part.centre) @ h.normal).max()) - half_thickness(part, h.normal)
    edges = part.bbox[[1, 3, 4]] - part.bbox[0]
    lengths = np.linalg.norm(edges, axis=1)
    dirs = edges / np.maximum(lengths[:, None], 1e-12)
    # the front face's two sides, the more vertical one its height (a lid's face is horizontal: either)
    face = sorted(np.argsort(np.abs(dirs @ t.front_normal))[:2], key=lambda i: abs(dirs[i][2]))
    row = {
        "category": obj.category,
        "target_part": part.category,
        "handle_category": handle_cat,
        "joint_type": "revolute" if joint.is_revolute else "prismatic",
        "handle_type": kind,
        "handle_tilt_deg": tilt if is_bar else None,
        "handle_length_m": scale * h.length,
        "handle_width_m": scale * h.width,
        "handle_thickness_m": scale * h.thickness,
        "handle_protrusion_m": scale * protrusion,
        "part_width_m": scale * float(lengths[face[0]]),
        "part_height_m": scale * float(lengths[face[1]]),
        "part_mass_kg": mass,
        "joint_range_m": None if joint.is_revolute else scale * (joint.upper - joint.lower),
        "joint_range_rad": joint.upper - joint.lower if joint.is_revolute else None,
        "hinge_radius_m": None,
        "hinge_side": None,
    }
    if joint.is_revolute:
        axis = joint.axis / np.linalg.norm(joint.axis)
        d = joint.origin - h.centre
        offset = d - (d @ axis) * axis
        row["hinge_radius_m"] = scale * float(np.linalg.norm(offset))
        row["hinge_side"] = hinge_side(offset, h.normal)
    return {k: round(float(v), 5) if isinstance(v, float) else v for k, v in row.items()}


def describe(folder: Path, config: SceneConfig) -> dict:
    """One object's row: its name, the quantities (the mass from the scene ``config`` builds) and, for a procedural
    object, the handle kind its generator drew (``meta.json``: an edge pull is a line handle to the loader, so the
    handle type above counts it as a bar)."""
    obj = load_gapartnet(folder)
    mass = float(build_scene(obj, config).stats["target_mass_kg"])
    meta = folder / "meta.json"
    generator = json.loads(meta.read_text()).get("generator", {}) if meta.is_file() else {}
    return {"object": obj.object_id, **quantities(obj, config.scale, mass),
            "generator_handle_kind": generator.get("handle_kind")}


def numeric_cell(values: list[float]) -> str:
    if not values:
        return "—"
    q = np.quantile(values, [0.0, 0.25, 0.5, 0.75, 1.0])
    return " · ".join(f"{x:.3g}" for x in q)


def inside(value: float, values: list[float]) -> bool:
    """Whether ``values`` (possibly none) span ``value``."""
    return bool(values) and min(values) <= value <= max(values)


def counts(rows: list[dict], key: str) -> dict[str, int]:
    out: dict[str, int] = {}
    for r in rows:
        if r[key] is not None:
            out[r[key]] = out.get(r[key], 0) + 1
    return dict(sorted(out.items(), key=lambda kv: -kv[1]))


def markdown(mixes: dict[str, list[dict]], real: list[dict], n: int, seed: int, scale: float) -> str:
    """The summary table: a row per quantity."""
    head = ["quantity", *(f"{MIXES[m]} ({len(rows)})" for m, rows in mixes.items()), *(r["object"] for r in real)]
    lines = [f"Procedural: {n} objects per mix, seeds from {seed}; real: {len(real)} objects. World frame (object "
             f"scale {scale:g}, z up), closed configuration. Numeric mix cells: min · q25 · median · q75 · max over "
             "the objects where the quantity applies; categorical: objects per value. A real object's marks say "
             f"whether each mix ({' / '.join(MIXES[m] for m in mixes)}) covers its value: its range holds "
             "it (✓) or not (✗); for a categorical one, whether any of its objects has that value.", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for key, title in CATEGORICAL.items():
        have = {m: counts(rows, key) for m, rows in mixes.items()}
        cells = [", ".join(f"{v} {k}" for v, k in c.items()) or "—" for c in have.values()]
        for r in real:
            marks = "/".join("✓" if r[key] in c else "✗" for c in have.values())
            cells.append("—" if r[key] is None else f"{r[key]} {marks}")
        lines.append(f"| {title} | " + " | ".join(cells) + " |")
    for key, title in NUMERIC.items():
        vals = {m: [r[key] for r in rows if r[key] is not None] for m, rows in mixes.items()}
        cells = [numeric_cell(v) for v in vals.values()]
        for r in real:
            if r[key] is None:
                cells.append("—")
                continue
            marks = "/".join("✓" if inside(r[key], v) else "✗" for v in vals.values())
            cells.append(f"{r[key]:.3g} {marks}")
        lines.append(f"| {title} | " + " | ".join(cells) + " |")
    lines += ["", "Against only each mix's objects of the same joint type (drawers against drawers, doors and lids "
              "against doors and lids), the numeric quantities of each real object out of the mix's range:", "",
              "| object | " + " | ".join(MIXES[m] for m in mixes) + " |", "|---|" + "---|" * len(mixes)]
    for r in real:
        cells = []
        for rows in mixes.values():
            same = [x for x in rows if x["joint_type"] == r["joint_type"]]
            out = [k for k in NUMERIC
                   if r[k] is not None and not inside(r[k], [x[k] for x in same if x[k] is not None])]
            cells.append(", ".join(out) or "none")
        lines.append(f"| {r['object']} ({r['target_part']}) | " + " | ".join(cells) + " |")
    kinds = {m: counts(rows, "generator_handle_kind") for m, rows in mixes.items()}
    if any(kinds.values()):
        lines += ["", "Handle kinds the generator drew (meta.json; objects whose generator records none are left out): "
                  + "; ".join(f"{MIXES[m]}: " + (", ".join(f"{v} {k}" for v, k in c.items()) or "—")
                              for m, c in kinds.items()) + "."]
    return "\n".join(lines) + "\n"


def figure(mixes: dict[str, list[dict]], real: list[dict]) -> Figure:
    """A panel per quantity: the mixes as histograms (bar charts for categorical quantities), each real object as a
    labelled vertical line."""
    keys = [*CATEGORICAL, *NUMERIC]
    cols = 4
    nrows = -(-len(keys) // cols)
    fig = Figure(figsize=(4.6 * cols, 3.4 * nrows + 0.6))
    axes = fig.subplots(nrows, cols, squeeze=False).ravel()
    mix_colours = {m: f"C{i}" for i, m in enumerate(mixes)}
    palette = colormaps["tab10"]
    real_colours = [palette((i + len(mixes)) % 10) for i in range(len(real))]
    for ax, key in zip(axes, keys, strict=False):
        ax.set_title({**CATEGORICAL, **NUMERIC}[key], fontsize=10)
        ax.set_ylabel("objects", fontsize=8)
        if key in CATEGORICAL:
            values = sorted({r[key] for rows in [*mixes.values(), real] for r in rows if r[key] is not None})
            x = np.arange(len(values))
            w = 0.8 / len(mixes)
            for i, (m, rows) in enumerate(mixes.items()):
                c = counts(rows, key)
                ax.bar(x - 0.4 + w * (i + 0.5), [c.get(v, 0) for v in values], w, color=mix_colours[m], alpha=0.7)
            ax.set_xticks(x, values, rotation=30, ha="right", fontsize=8)
            spots = [(values.index(r[key]) + 0.07 * (j - (len(real) - 1) / 2), r, real_colours[j])
                     for j, r in enumerate(real) if r[key] is not None]
        else:
            vals = {m: [r[key] for r in rows if r[key] is not None] for m, rows in mixes.items()}
            spots = [(r[key], r, real_colours[j]) for j, r in enumerate(real) if r[key] is not None]
            everything = [v for vs in vals.values() for v in vs] + [s[0] for s in spots]
            if not everything:
                ax.text(0.5, 0.5, "does not apply", ha="center", va="center", transform=ax.transAxes)
                continue
            lo, hi = min(everything), max(everything)
            pad = 0.05 * (hi - lo) or 0.05 * abs(hi) or 0.05
            bins = np.linspace(lo - pad, hi + pad, 25)
            for m, vs in vals.items():
                ax.hist(vs, bins, color=mix_colours[m], alpha=0.5)
            ax.tick_params(labelsize=8)
        for xpos, r, colour in spots:
            ax.axvline(xpos, color=colour, lw=1.8)
            ax.text(xpos, 0.97, f" {r['object']}", rotation=90, va="top", ha="right", fontsize=7, color=colour,
                    transform=ax.get_xaxis_transform())
    for ax in axes[len(keys):]:
        ax.set_visible(False)
    handles = [Patch(color=mix_colours[m], alpha=0.6, label=f"procedural: {MIXES[m]} "
                                        f"({len(rows)})") for m, rows in mixes.items()]
    handles += [Line2D([], [], color=c, lw=1.8, label=f"{r['object']} ({r['category']}, "
                                        f"{r['target_part']})") for r, c in zip(real, real_colours, strict=True)]
    fig.legend(handles=handles, loc="lower center", ncol=min(len(handles), 3), fontsize=9, frameon=False)
    fig.tight_layout(rect=(0, 0.6 / (3.4 * nrows + 0.6), 1, 1))
    return fig


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--procedural", type=int, default=64, help="procedural objects per mix (default 64)")
    ap.add_argument("--seed", type=int, default=1000, help="first procedural seed (default 1000, the generalist's)")
    ap.add_argument("--real", nargs="*", default=[], help="real object folders (GAPartNet format)")
    ap.add_argument("--out", default="results/coverage", help="output folder (default results/coverage)")
    a = ap.parse_args(argv)
    if a.procedural < 1:
        ap.error(f"--procedural must be at least 1, got {a.procedural}")
    config = SceneConfig(effector="parallel_jaw")  # the part mass does not depend on the effector
    with tempfile.TemporaryDirectory(prefix="coverage_") as tmp:
        folders = {"table1": synthesize_table1(a.procedural, a.seed, tmp),
                   "all": [p for c, k in category_mix(a.procedural).items() for p in synthesize(c, k, a.seed, tmp)]}
        rows: dict[Path, dict] = {}
        for mix, paths in folders.items():
            for p in paths:
                if p not in rows:
                    rows[p] = {**describe(p, config), "source": "procedural", "mixes": []}
                rows[p]["mixes"].append(mix)
    real, skipped = [], []
    for folder in map(Path, a.real):
        try:
            real.append({**describe(folder, config), "source": "real", "folder": str(folder)})
        except DragMeshError as e:
            print(f"skipped {folder}: {e}", file=sys.stderr)
            skipped.append({"folder": str(folder), "error": str(e)})
    mixes = {m: [rows[p] for p in paths] for m, paths in folders.items()}
    out = Path(a.out)
    atomic_write_json(out / "coverage.json", {
        "procedural_per_mix": a.procedural, "seed": a.seed, "scale": config.scale,
        "mixes": {m: {"title": MIXES[m], "objects": [r["object"] for r in rs]} for m, rs in mixes.items()},
        "quantities": {**CATEGORICAL, **NUMERIC}, "rows": [*rows.values(), *real], "skipped": skipped})
    atomic_write_text(out / "coverage.md", markdown(mixes, real, a.procedural, a.seed, config.scale))
    atomic_write_figure(out / "coverage.png", figure(mixes, real), dpi=110)
    print(f"{len(rows)} procedural and {len(real)} real objects ({len(skipped)} skipped): "
          f"{out}/coverage.{{json,md,png}}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
