"""A validation suite of procedural doors chosen by the expert's envelope (issue "Hold on and follow", item 1): doors,
microwaves and refrigerators on which today's expert drag lets go under load as it does on the paper's hardest
unseen doors, and thick handles on heavy doors.

    python experiments/door_suite.py --candidates 12 --seed 100 --out results/suite

Each candidate is a procedural object (``objects synth --category C --count 1 --seed S``) with its trajectory; its
envelope is the expert drag replayed on the C engine from its exact grasp at each pace x damping
(``physics.contacts.replay``, within the task's episode). The rule, written before the runs:

  * ``lets_go``: not opened at x4 at the expert's own pace and at x8 at no pace (the paper's hardest cabinet door);
  * ``lags``: else not opened at x4 or at x8 at the expert's own pace (only slower, where at all);
  * ``thick_heavy``: a handle at least THICK m thick on a part of at least HEAVY kg (the microwave's 46 mm on 2 kg);
  * the suite: every ``lets_go``, ``lags`` and ``thick_heavy`` candidate whose trajectory passed its gate, then the
    heaviest of the rest, to SIZE objects.

Writes OUT/candidates.jsonl (every candidate: category, seed, mass, handle, gate, envelope, classes) and
OUT/suite.json (the chosen: category, seed and why), read by ``tests/experiments/test_door_suite.py``."""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np

from dragmesh2_jax.assets.procedural import synthesize
from dragmesh2_jax.io import atomic_write_json, atomic_write_text
from dragmesh2_jax.physics.contacts import replay
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.task.starts import reset_starts

CATEGORIES = ("door_cabinet", "microwave", "refrigerator")
PACES = (0.33, 0.5, 1.0)
DAMPINGS = (1.0, 4.0, 8.0)
THICK, HEAVY = 0.018, 1.0  # m (world: 46 mm at the paper's scale is 18 mm at the scene's 0.4), kg
SIZE = 24


def envelope(task) -> dict[str, bool]:
    """Whether the expert drag opens the part at each ``pace x damping`` (keys ``"0.5@4"``) within the episode."""
    scene, traj, config = task.scene, task.traj, task.config
    lo, hi = scene.ids.hand_range[:, 0], scene.ids.hand_range[:, 1]
    start = reset_starts(scene, traj, None)[0]
    out = {}
    for pace in PACES:
        targets = traj.drag_targets(config.control_dt, pace)
        targets = np.clip(targets[np.minimum(np.arange(config.episode_length), len(targets) - 1)], lo, hi)
        for damping in DAMPINGS:
            r = replay(scene, start, targets, task.substeps, config.settle_substeps, traj.q_done_at(config.rho),
                       damping)
            out[f"{pace:g}@{damping:g}"] = r.steps is not None
    return out


def classes(env: dict[str, bool], mass: float, thickness: float) -> list[str]:
    """The rule's classes of a candidate (the module's text) from its envelope, part mass (kg) and handle (m)."""
    out = []
    if not env["1@4"] and not any(env[f"{p:g}@8"] for p in PACES):
        out.append("lets_go")
    elif not env["1@4"] or not env["1@8"]:
        out.append("lags")
    if thickness >= THICK and mass >= HEAVY:
        out.append("thick_heavy")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--candidates", type=int, default=12, help="per category")
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for category in CATEGORIES:
            for folder in synthesize(category, args.candidates, args.seed, Path(tmp) / category):
                task = load_task(str(folder), None, backend="mujoco")
                mass, thickness = task.scene.stats["target_mass_kg"], float(task.scene.handle.thickness)
                passed = bool(task.traj.header["quality"]["passed"])
                env = envelope(task) if passed else {}
                rows.append({"category": category, "seed": int(folder.name.rsplit("_", 1)[1]), "mass_kg": mass,
                             "handle_thickness_m": round(thickness, 4), "gate": passed, "envelope": env,
                             "classes": classes(env, mass, thickness) if passed else []})
                print(json.dumps(rows[-1]), flush=True)
    atomic_write_text(out / "candidates.jsonl", "".join(json.dumps(r) + "\n" for r in rows))
    chosen = [r for r in rows if r["gate"] and r["classes"]]
    rest = sorted((r for r in rows if r["gate"] and not r["classes"]), key=lambda r: -r["mass_kg"])
    suite = (chosen + rest)[:max(SIZE, len(chosen))]
    atomic_write_json(out / "suite.json", {
        "rule": {"paces": PACES, "dampings": DAMPINGS, "thick_m": THICK, "heavy_kg": HEAVY, "size": SIZE},
        "objects": [{k: r[k] for k in ("category", "seed", "mass_kg", "handle_thickness_m", "classes")}
                    for r in suite]})


if __name__ == "__main__":
    main()
