"""Where the generalist fails: the packaged generalist (or a run's checkpoint) on every object of its own procedural
mix, those it trained on and those held aside (one per category), deterministic, per category.

    python experiments/generalist_procedural.py OUT [--checkpoint generalist] [--damping 1,4] [--episodes 20]

Builds the mix (``runs/generalist.generalist_objects``: the objects ``train --generalist`` trains on) into
``OUT/objects`` unless there, evaluates each object zero-shot (its trajectory from the mix's dataset) and writes
``OUT/procedural.json`` (every cell) and prints a table of success by category, trained on vs held aside.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from collections import defaultdict
from pathlib import Path

from dragmesh2_jax.assets.procedural import category_of
from dragmesh2_jax.evaluation.protocol import PAPER
from dragmesh2_jax.io import atomic_write_json
from dragmesh2_jax.runs.commands import evaluate_checkpoint
from dragmesh2_jax.runs.generalist import GENERALIST, generalist_objects


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out")
    p.add_argument("--checkpoint", default=GENERALIST)
    p.add_argument("--damping", default="1,4")
    p.add_argument("--episodes", type=int, default=20)
    args = p.parse_args()
    out = Path(args.out)
    objects, trajectories, held = generalist_objects(out, progress=False)
    protocol = dataclasses.replace(PAPER, dampings=tuple(float(d) for d in args.damping.split(",")),
                                   modes=("det",), episodes=args.episodes)
    dest = out / "procedural.json"
    rows = json.loads(dest.read_text())["objects"] if dest.is_file() else {}
    for i, (obj, traj) in enumerate(zip(objects, trajectories, strict=True)):
        name = Path(obj).name
        if name in rows:
            continue
        result, _ = evaluate_checkpoint(args.checkpoint, protocol, "mujoco", object_dir=obj, trajectory=traj)
        rows[name] = {"held_aside": i >= len(objects) - held, "cells": result["cells"]}
        print(name, " ".join(f"x{c['damping']:g} {c['success_rate']:.2f}" for c in result["cells"]), flush=True)
        atomic_write_json(dest, {"checkpoint": args.checkpoint, "protocol": protocol.name, "objects": rows})
    table = defaultdict(lambda: defaultdict(list))
    for name, row in rows.items():
        for c in row["cells"]:
            table[category_of(name)][(row["held_aside"], c["damping"])].append(c["success_rate"])
    print("category | trained on: " + " / ".join(f"x{d:g}" for d in protocol.dampings) + " | held aside")
    for cat, cells in sorted(table.items()):
        print(f"{cat} | {_means(cells, False, protocol.dampings)} (n={len(cells[(False, protocol.dampings[0])])}) | "
              f"{_means(cells, True, protocol.dampings)}")


def _means(cells: dict, held: bool, dampings: tuple[float, ...]) -> str:
    return " / ".join(f"{sum(v) / len(v):.2f}" if (v := cells[(held, d)]) else "-" for d in dampings)


if __name__ == "__main__":
    main()
