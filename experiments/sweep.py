"""Reproduce the paper's comparison tables: train every (object, method, seed), evaluate at damping
x1/x2/x4 in det and stoch mode, and write Table 2/3-style markdown (per-object det/stoch success and Avg).

    python experiments/sweep.py --objects ../shared/gapartnet/45261 ../shared/gapartnet/45661 \\
        --methods pica,state_only,flat_history,gru,transformer,gla_only,pica_flat --epochs 150 --out runs/sweep

Resumable: finished runs (an eval file present) are skipped, interrupted ones resume from their checkpoint.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from dragmesh2_jax.cli import _floats_arg, load_run, make_trainer
from dragmesh2_jax.evaluation.evaluate import evaluate
from dragmesh2_jax.io import atomic_write_json, atomic_write_text
from dragmesh2_jax.ppo.runner import latest_checkpoint, train


def run_one(obj: str, method: str, seed: int, args) -> dict:
    run_dir = Path(args.out) / Path(obj).name / f"{method}_s{seed}"
    result_path = run_dir / f"eval_{args.checkpoint}.json"
    if result_path.is_file():
        return json.loads(result_path.read_text())
    resume = latest_checkpoint(run_dir) is not None
    if resume:
        trainer, _, _ = load_run(str(latest_checkpoint(run_dir)), args.backend)
    else:
        trainer = make_trainer(obj, None, method, args.backend, "jax", epochs=args.epochs, num_envs=args.num_envs,
                               seed=seed)
    if not (run_dir / "checkpoints" / "final.npz").is_file():
        train(trainer, run_dir, obj, resume=resume, save_every=25, progress=not args.quiet)
    trainer, ts, _ = load_run(str(run_dir / "checkpoints" / f"{args.checkpoint}.npz"), args.backend)
    res = evaluate(trainer, ts, _floats_arg(args.damping, "--damping"), ["det", "stoch"], args.episodes, seed=seed)
    atomic_write_json(result_path, res)
    return res


def table(results: dict, objects: list[str], dampings: list[float]) -> str:
    head = "| Method | Damp | " + " | ".join(Path(o).name for o in objects) + " | Avg |"
    lines = [head, "|" + "---|" * (len(objects) + 3)]
    for method, per_obj in results.items():
        for d in dampings:
            cells, dets, stos = [], [], []
            for o in objects:
                rs = per_obj.get(Path(o).name)
                if rs is None:
                    cells.append("-")
                    continue
                rate = {c["mode"]: c["success_rate"] for c in rs["cells"] if c["damping"] == d}
                dets.append(rate["det"])
                stos.append(rate["stoch"])
                cells.append(f"{dets[-1]:.2f}/{stos[-1]:.2f}")
            avg = f"{sum(dets) / len(dets):.2f}/{sum(stos) / len(stos):.2f}" if dets else "-"
            lines.append(f"| {method} | x{d:g} | " + " | ".join(cells) + f" | {avg} |")
    return "\n".join(lines)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--objects", nargs="+", required=True)
    p.add_argument("--methods", default="pica,state_only")
    p.add_argument("--seeds", default="42")
    p.add_argument("--epochs", type=int, default=150)
    p.add_argument("--num-envs", type=int, default=64)
    p.add_argument("--damping", default="1,2,4")
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--checkpoint", default="best", choices=["best", "final"])
    p.add_argument("--backend", default="auto")
    p.add_argument("--out", default="runs/sweep")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args()
    dampings = _floats_arg(args.damping, "--damping")
    results: dict = {}
    for method in args.methods.split(","):
        for obj in args.objects:
            for seed in (int(s) for s in args.seeds.split(",")):
                res = run_one(obj, method, seed, args)
                results.setdefault(method, {})[Path(obj).name] = res  # last seed shown; JSON keeps each
    md = "# Success (deterministic / stochastic)\n\n" + table(results, args.objects, dampings) + "\n"
    atomic_write_text(Path(args.out) / "table.md", md)
    print(md)


if __name__ == "__main__":
    main()
