"""Issue 56: does a batch that mixes every procedural category on the one-structure template step as fast as one
object in its own structure? Per engine, the packaged drawer alone (its own scene: no parked parts) against one
object of every category of the generalist's mix on the template (each world steps one), side by side in one process
(``bench.bench_env_pair``: both compiled, then timed in turn, so a drifting CPU weighs on both alike).

    python experiments/mixed_structure_speed.py --out results/speed/mixed_structure.json \\
        [--engines mujoco:64:100,mjx-jax:16:10,mjx-warp:16:10] [--rounds 5] [--train mujoco:64,mjx-warp:16]

An engine is NAME:WORLDS:STEPS (``bench env``); ``--train`` NAME:ENVS times the generalist's training epochs instead
(``bench train``: the method ``generalist`` over the mix against the drawer alone). Writes OUT (JSON: one row per
engine) and prints a markdown table."""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from dragmesh2_jax.assets import procedural
from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.bench import bench_env_pair, bench_train_pair
from dragmesh2_jax.io import atomic_write_json
from dragmesh2_jax.physics.engines import avoid_lapack_deadlock
from dragmesh2_jax.runs.build import load_task, mix_of, program_of
from dragmesh2_jax.runs.generalist import GENERALIST
from dragmesh2_jax.runs.spec import method_spec
from dragmesh2_jax.scene import TEMPLATE_SLOTS
from dragmesh2_jax.trajectory.generator import generate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--engines", default="mujoco:64:100,mjx-jax:16:10,mjx-warp:16:10")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--train", help="NAME:ENVS,...: the generalist's training epochs instead of random steps")
    args = ap.parse_args()
    avoid_lapack_deadlock()  # before the C engine's rows start JAX (MJX-JAX on a CPU: RESULTS.md §1)
    folder = Path(tempfile.mkdtemp(prefix="mixed_structure_"))
    objects = procedural.synthesize_mix(dict.fromkeys(procedural.GENERALIST_MIX, 1), procedural.GENERALIST_SEED, folder)
    one = procedural.default_object()
    if args.train:
        return train_pairs(args, objects, one)
    trajectories = [generate(load_gapartnet(o)) for o in objects]
    rows = []
    for engine in args.engines.split(","):
        name, worlds, steps = engine.split(":")
        backend, impl = engine_of(name)
        mixed = mix_of([load_task(str(o), t, backend, impl, slots=TEMPLATE_SLOTS)
                        for o, t in zip(objects, trajectories, strict=True)])
        pair = bench_env_pair(mixed, load_task(str(one), None, backend, impl), int(worlds), int(steps), args.rounds)
        rows.append(pair)
        m, b = pair["task"], pair["baseline"]
        print(f"{m['engine']}: {worlds} worlds, mixed {m['objects']} categories {m['physics_steps_per_s']:.0f}/s "
              f"(compile {m['compile_s']:.0f} s), one object {b['physics_steps_per_s']:.0f}/s (compile "
              f"{b['compile_s']:.0f} s), ratio {pair['ratio']:.2f} ({pair['ratio_min']:.2f}-{pair['ratio_max']:.2f})",
              flush=True)
        atomic_write_json(args.out, rows)
    print("\n| engine | worlds | mixed (10 categories) physics steps/s | one object physics steps/s | ratio (min-max) |"
          " compile mixed / one |\n|---|---|---|---|---|---|")
    for p in rows:
        m, b = p["task"], p["baseline"]
        print(f"| {m['engine']} | {m['num_envs']} | {m['physics_steps_per_s']:,.0f} | {b['physics_steps_per_s']:,.0f} "
              f"| {p['ratio']:.2f} ({p['ratio_min']:.2f}-{p['ratio_max']:.2f}) | {m['compile_s']:.0f} s / "
              f"{b['compile_s']:.0f} s |")


def engine_of(name: str) -> tuple[str, str]:
    """(backend, impl) of an engine's name (``bench.engine_name``'s: mujoco, mjx-jax, mjx-warp)."""
    return ("mujoco", "jax") if name == "mujoco" else ("mjx", name.split("-")[1])


def train_pairs(args, objects: list[Path], one: Path) -> None:
    rows = []
    for engine in args.train.split(","):
        name, envs = engine.split(":")
        backend, impl = engine_of(name)
        mixed, alone = (program_of(method_spec(GENERALIST, o, {"num_envs": int(envs)}, backend=backend, impl=impl))
                        for o in ([str(p) for p in objects], str(one)))
        pair = bench_train_pair(mixed, alone, rounds=args.rounds)
        rows.append(pair)
        m, b = pair["program"], pair["baseline"]
        print(f"{m['engine']}: {envs} envs, mixed {m['objects']} categories {m['s_per_epoch']:.3f} s/epoch (first "
              f"{m['first_epoch_s']:.0f} s), alone {b['s_per_epoch']:.3f} s/epoch (first {b['first_epoch_s']:.0f} s), "
              f"ratio {pair['ratio']:.2f} ({pair['ratio_min']:.2f}-{pair['ratio_max']:.2f})", flush=True)
        atomic_write_json(args.out, rows)


if __name__ == "__main__":
    main()
