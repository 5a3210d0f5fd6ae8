"""Where the hand's penetration into a handle comes from, one cause at a time: the expert drag replayed on the C
engine from the exact grasp (``task.expert.expert_replay``) under each grasp (generator parameters) x object contacts
(``SceneConfig.object_contact``), and on the seated grasp with the hand's contacts each solver setting changed alone.

    python experiments/penetration_causes.py --objects A B ... --out results/penetration [--damping 1,4,8]

Writes OUT/causes.jsonl (one row per object x grasp x contacts x solver x damping) and OUT/table.md."""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
from pathlib import Path

import mujoco
import numpy as np

from dragmesh2_jax.io import atomic_write_text
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.task.expert import expert_replay
from dragmesh2_jax.trajectory.generator import SEAT_DEPTH, GeneratorParams, generate

GRASPS = {"planned (the default)": GeneratorParams(),
          "seated 0.5 mm, grip 0.04": GeneratorParams(seat_depth=0.0005),
          "seated, grip 0.04": GeneratorParams(seat_depth=SEAT_DEPTH),
          "seated, grip 0.2": GeneratorParams(seat_depth=SEAT_DEPTH, grip_closure=0.2)}
#: The pair each solver setting is changed on: the seated grasp (``TaskConfig.expert_grasp``) on the hand's contacts.
SEATED = "seated, grip 0.04"


def _solimp(m, ids):
    m.geom_solimp[np.concatenate([ids.hand_geoms, ids.object_collision_geoms])] = [0.99, 0.999, 0.001, 0.5, 2]


def _iterations(m, ids):
    m.opt.iterations, m.opt.ls_iterations = 50, 50


def _elliptic(m, ids):
    m.opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC


def _impratio(m, ids):
    m.opt.impratio = 10.0


def _finger_force(m, ids):
    m.actuator_forcerange[ids.hand_actuators[6:]] = [-0.3, 0.3]


SOLVER = {"": None, "solimp 0.99 0.999": _solimp, "solver 50 iterations": _iterations, "elliptic cone": _elliptic,
          "impratio 10": _impratio, "finger force 0.3 N m": _finger_force}


def _changed(scene, change):
    """``scene`` whose model ``change`` edits (a copy; the scene's own model is left alone)."""
    if change is None:
        return scene
    m = copy.deepcopy(scene.model)
    change(m, scene.ids)
    return dataclasses.replace(scene, model=m)


def table(rows: list[dict], dampings: list[float]) -> str:
    """One line per object x contacts x grasp x solver: the deepest penetration (mm), the peak wrist load (N) and the
    steps to open (- where it did not) at each damping."""
    head = " | ".join(f"x{d:g}: deepest, load, steps" for d in dampings)
    lines = [f"| object | object contacts | grasp | solver | {head} |", "|---" * (4 + len(dampings)) + "|"]
    keys = dict.fromkeys((r["object"], r["contacts"], r["grasp"], r["solver"]) for r in rows)
    for key in keys:
        cells = {r["damping"]: r for r in rows if (r["object"], r["contacts"], r["grasp"], r["solver"]) == key}
        shown = [f"{cells[d]['deepest_mm']:.1f} mm, {cells[d]['peak_load_n']:.0f} N, {cells[d]['steps'] or '-'}"
                 for d in dampings]
        lines.append(f"| {' | '.join(key[:3])} | {key[3] or '-'} | " + " | ".join(shown) + " |")
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--objects", nargs="+", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--damping", default="1,4,8")
    args = ap.parse_args()
    dampings = [float(x) for x in args.damping.split(",")]
    rows = []
    for o in args.objects:
        name = Path(o).name
        for contacts in ("mujoco", "hand"):
            task = load_task(o, None, backend="mujoco", scene_config=SceneConfig(object_contact=contacts))
            for grasp_name, params in GRASPS.items():
                traj = generate(task.scene.obj, params, scene=task.scene)
                for solver, change in SOLVER.items():
                    if solver and (contacts != "hand" or grasp_name != SEATED):
                        continue
                    scene = _changed(task.scene, change)
                    for damping in dampings:
                        r = expert_replay(scene, traj, task.config, task.substeps, damping)
                        rows.append({"object": name, "contacts": contacts, "grasp": grasp_name, "solver": solver,
                                     "damping": damping, "deepest_mm": round(1000 * r.deepest, 2),
                                     "peak_load_n": round(r.peak_load, 1), "steps": r.steps})
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "causes.jsonl", "".join(json.dumps(r) + "\n" for r in rows))
    atomic_write_text(out / "table.md", table(rows, dampings))


if __name__ == "__main__":
    main()
