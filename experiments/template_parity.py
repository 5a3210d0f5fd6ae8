"""Issue 56: the packaged generalist on one object of every category of its mix, each in its own structure on the C
engine and on the one-structure template on MJX (``scene.build_scene(..., slots=n)``: what an MJX mix trains on),
the same policy, protocol and starts: success per object with its interval, wrist load and steps.

    python experiments/template_parity.py --out results/speed/template_parity.json [--impl warp] [--episodes 10]
        [--damping 1]

Writes OUT (JSON: one row per object and engine) and prints a markdown table."""

from __future__ import annotations

import argparse
import dataclasses
import math
import tempfile
from pathlib import Path

from dragmesh2_jax.assets import procedural
from dragmesh2_jax.evaluation.evaluate import evaluate
from dragmesh2_jax.evaluation.protocol import EvalProtocol
from dragmesh2_jax.io import atomic_write_json
from dragmesh2_jax.physics.engines import avoid_lapack_deadlock
from dragmesh2_jax.runs.commands import load_run
from dragmesh2_jax.runs.generalist import GENERALIST
from dragmesh2_jax.scene import TEMPLATE_SLOTS
from dragmesh2_jax.task.load import task_of


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """The 95% Wilson interval of k successes in n episodes."""
    p, d = k / n, 1 + z * z / n
    c, h = (p + z * z / (2 * n)) / d, z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return max(0.0, c - h), min(1.0, c + h)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--impl", default="warp")
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--damping", type=float, default=1.0)
    args = ap.parse_args()
    avoid_lapack_deadlock()  # before the C engine starts JAX (MJX-JAX on a CPU: RESULTS.md §1)
    folder = Path(tempfile.mkdtemp(prefix="template_parity_"))
    objects = procedural.synthesize_mix(dict.fromkeys(procedural.GENERALIST_MIX, 1), procedural.GENERALIST_SEED, folder)
    protocol = EvalProtocol(dampings=(args.damping,), modes=("det",), episodes=args.episodes)
    rows = []
    for o in objects:
        program, ts, _, _ = load_run(GENERALIST, "mujoco", object_dir=str(o))
        controller, own = program.controller(ts), program.task
        config = dataclasses.replace(own.config, backend="mjx", impl=args.impl)
        template = task_of(str(o), own.traj, config, own.scene.config, TEMPLATE_SLOTS)
        for engine, task in (("mujoco (own structure)", own), (f"mjx-{args.impl} (template)", template)):
            (cell,) = evaluate(protocol.task(task), controller, protocol)["cells"]
            lo, hi = wilson(cell["successes"], args.episodes)
            rows.append({"object": o.name, "engine": engine, "success_rate": cell["success_rate"], "low": lo,
                         "high": hi, "steps_mean": cell["steps_mean"], "wrist_load_peak_n": cell["wrist_load_peak_n"]})
            print(f"{o.name:24s} {engine:24s} success {cell['success_rate']:.2f} [{lo:.2f}, {hi:.2f}] steps "
                  f"{cell['steps_mean']:.0f} load {cell['wrist_load_peak_n']:.0f} N", flush=True)
            atomic_write_json(args.out, rows)
    print(f"\n| object | C engine (own) success [95%] | MJX-{args.impl} (template) success [95%] | steps C / MJX | "
          "wrist load p95 C / MJX |\n|---|---|---|---|---|")
    for a, b in zip(rows[::2], rows[1::2], strict=True):
        print(f"| {a['object']} | {a['success_rate']:.2f} [{a['low']:.2f}, {a['high']:.2f}] | {b['success_rate']:.2f} "
              f"[{b['low']:.2f}, {b['high']:.2f}] | {a['steps_mean']:.0f} / {b['steps_mean']:.0f} | "
              f"{a['wrist_load_peak_n']:.0f} / {b['wrist_load_peak_n']:.0f} N |")


if __name__ == "__main__":
    main()
