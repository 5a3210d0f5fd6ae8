"""The comparison tables (paper Tables 2/3 layout): train every (object, method, seed), evaluate the run's
``best_robust`` checkpoint at damping x1/x2/x4 in det and stoch mode from perturbed starts (the evaluation
protocol: each cell a rate over ``--episodes`` episodes), and write per-object det/stoch success as mean and
standard error over seeds, with the active-DoF clip099 beside it.

    python experiments/sweep.py --objects ../shared/gapartnet/45780 ../shared/gapartnet/11712 \\
        --methods state_only,pica,pica_load --seeds 0,1,2 --epochs 150 --out runs/sweep

A method ``BASE+RECIPE`` (e.g. ``pica+damp_1_4``) is the fine-tune preset RECIPE started from the best_robust
checkpoint of the same seed's BASE run (trained first if missing): its budget is BASE's plus the recipe's epochs.

Resumable: finished runs (an eval file present) are skipped, interrupted ones resume from their checkpoint.
Every run's evaluation is kept (``<out>/<object>/<method>_s<seed>/eval_*.json``); ``results.json`` collects them.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from dragmesh2_jax.evaluation.evaluate import evaluate
from dragmesh2_jax.io import atomic_write_json, atomic_write_text
from dragmesh2_jax.ppo.checkpoint import find_checkpoint
from dragmesh2_jax.ppo.runner import latest_checkpoint, train
from dragmesh2_jax.runs import eval_task, load_run, make_finetune, make_trainer, parse_floats


def run_one(obj: str, method: str, seed: int, args) -> dict:
    run_dir = Path(args.out) / Path(obj).name / f"{method}_s{seed}"
    result_path = run_dir / "eval_best_robust.json"
    if result_path.is_file():
        return json.loads(result_path.read_text())
    base, _, recipe = method.partition("+")
    t0 = time.time()
    if not find_checkpoint(run_dir, "final"):
        last = latest_checkpoint(run_dir)
        if last is not None:  # interrupted: resume exactly (a fine-tune's record names its recipe)
            trainer, _, _, _ = load_run(last, args.backend)
            train(trainer, run_dir, obj, resume=True, save_every=25, progress=not args.quiet)
        elif recipe:
            parent = Path(args.out) / Path(obj).name / f"{base}_s{seed}"
            if not find_checkpoint(parent, "final"):
                run_one(obj, base, seed, args)
            trainer, start, ck = make_finetune(parent, recipe, args.backend)
            train(trainer, run_dir, obj, save_every=25, progress=not args.quiet, start=start,
                  meta={"finetune": recipe, "parent": str(ck.resolve())})
        else:
            trainer = make_trainer(obj, None, method, args.backend, "jax", epochs=args.epochs,
                                   num_envs=args.num_envs, seed=seed)
            train(trainer, run_dir, obj, save_every=25, progress=not args.quiet)
    trainer, ts, _, ck = load_run(run_dir, args.backend)  # best_robust
    res = evaluate(eval_task(trainer.task), trainer.controller(ts), parse_floats(args.damping, "--damping"),
                   ["det", "stoch"], args.episodes, seed=seed)
    res.update(checkpoint=str(ck), seed=seed, train_eval_seconds=round(time.time() - t0, 1))
    atomic_write_json(result_path, res)
    return res


def mean_se(xs: list[float]) -> tuple[float, float]:
    a = np.asarray(xs, float)
    return float(a.mean()), float(a.std(ddof=1) / np.sqrt(len(a))) if len(a) > 1 else 0.0


def table(results: dict, objects: list[str], dampings: list[float]) -> str:
    """results[method][object] = list of eval dicts (one per seed) -> markdown: det/stoch mean +- SE."""
    names = [Path(o).name for o in objects]
    lines = ["| Method | Damp | " + " | ".join(f"{n} det / stoch" for n in names) + " | Avg det / stoch | "
             "clip099 active (det) |", "|" + "---|" * (len(names) + 4)]
    for method, per_obj in results.items():
        for d in dampings:
            cells, avg = [], {"det": [], "stoch": []}
            clip = []
            for n in names:
                runs = per_obj.get(n, [])
                if not runs:
                    cells.append("-")
                    continue
                txt = []
                for mode in ("det", "stoch"):
                    rates = [next(c["success_rate"] for c in r["cells"] if c["damping"] == d and c["mode"] == mode)
                             for r in runs]
                    m, se = mean_se(rates)
                    avg[mode].append(m)
                    txt.append(f"{m:.2f}±{se:.2f}")
                clip += [next(c["clip099_active"] for c in r["cells"] if c["damping"] == d and c["mode"] == "det")
                         for r in runs]
                cells.append(" / ".join(txt) + f" (n={len(runs)})")
            a = " / ".join(f"{np.mean(avg[m]):.2f}" for m in ("det", "stoch")) if avg["det"] else "-"
            c = f"{np.mean(clip):.2f}" if clip else "-"
            lines.append(f"| {method} | x{d:g} | " + " | ".join(cells) + f" | {a} | {c} |")
    return "\n".join(lines)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--objects", nargs="+", required=True)
    p.add_argument("--methods", default="state_only,pica,pica_load")
    p.add_argument("--seeds", default="0,1,2")
    p.add_argument("--epochs", type=int, default=150)
    p.add_argument("--num-envs", type=int, default=64)
    p.add_argument("--damping", default="1,2,4")
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--backend", default="auto")
    p.add_argument("--out", default="runs/sweep")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args()
    dampings = parse_floats(args.damping, "--damping", minimum=0.0)
    methods = args.methods.split(",")
    results: dict = {m: {} for m in methods}
    for seed in (int(s) for s in args.seeds.split(",")):  # seed-major: partial sweeps stay balanced
        for obj in args.objects:
            for method in methods:
                res = run_one(obj, method, seed, args)
                results[method].setdefault(Path(obj).name, []).append(res)
                md = ("# Success from perturbed starts (mean ± standard error over seeds; det / stoch)\n\n"
                      + table(results, args.objects, dampings) + "\n")
                atomic_write_text(Path(args.out) / "table.md", md)
                atomic_write_json(Path(args.out) / "results.json", results)
    print(md)


if __name__ == "__main__":
    main()
