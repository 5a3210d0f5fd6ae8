"""Package a trained generalist run as the one the project ships (``dragmesh2_jax/data/generalist``: the exported actor,
the run record, the command that trained it), then evaluate it zero-shot on the shared objects.

    python experiments/package_generalist.py RUN "dragmesh2 train --generalist --out RUN --seed 0" [--episodes 20]

The checkpoint packaged is the run's policy checkpoint (the generalist's rule: its final one); ``--checkpoint`` names
another (e.g. ``RUN/checkpoints/epoch_3000`` of a run still training). The evaluations land in
``results/generalist_v2/packaged_zero_shot.json``.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from dragmesh2_jax.evaluation.protocol import PAPER
from dragmesh2_jax.io import atomic_write_json
from dragmesh2_jax.runs.commands import evaluate_checkpoint
from dragmesh2_jax.runs.generalist import GENERALIST, package_run
from dragmesh2_jax.runs.rundir import ACTOR_NAME, PACKAGED

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "gapartnet"
OBJECTS = ("45261", "45661", "45780", "11712")  # tuning (45261, 45661) and validation (45780, 11712)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("run")
    p.add_argument("command", help="the exact command that trained the run")
    p.add_argument("--checkpoint", help="a checkpoint of the run (default: its policy checkpoint)")
    p.add_argument("--episodes", type=int, default=20, help="episodes per cell of the zero-shot evaluation")
    p.add_argument("--out", default=str(ROOT / "results" / "generalist_v2" / "packaged_zero_shot.json"))
    args = p.parse_args()
    dest = package_run(args.checkpoint or args.run, PACKAGED[GENERALIST], args.command)
    print(f"packaged: {dest} ({(dest / ACTOR_NAME).stat().st_size / 2**20:.2f} MB actor)")
    protocol = dataclasses.replace(PAPER, dampings=(1.0, 2.0, 4.0, 8.0), episodes=args.episodes)
    rows = {}
    for oid in OBJECTS:
        result, _ = evaluate_checkpoint(GENERALIST, protocol, "mujoco", object_dir=str(SHARED / oid))
        rows[oid] = result["cells"]
        print(oid, " ".join(f"x{c['damping']:g} {c['mode']} {c['success_rate']:.2f}" for c in result["cells"]))
    atomic_write_json(args.out, {"protocol": protocol.name, "objects": rows})


if __name__ == "__main__":
    main()
