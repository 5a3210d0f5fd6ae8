"""Our PPO against brax's PPO (an independent implementation) on the state-only baseline, at the same budget.

    python experiments/brax_check.py --seeds 0,1,2 --epochs 150 --out results/brax_check

Both train the state-only preset's task (exact expert-grasp start, nominal damping) for ``epochs`` x num_envs x
rollout_len environment steps with the same hyper-parameters (``baselines/brax_ppo.py``); both final policies
are evaluated by the same evaluator (perturbed starts, damping x1/x2/x4, 20 episodes per cell).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.baselines.brax_ppo import train_brax_ppo
from dragmesh2_jax.evaluation.evaluate import evaluate
from dragmesh2_jax.evaluation.protocol import PAPER
from dragmesh2_jax.io import atomic_write_json
from dragmesh2_jax.ppo.train import TrainProgram, epoch_jit, init_jit, seed_keys
from dragmesh2_jax.runs.build import program_of
from dragmesh2_jax.runs.commands import parse_floats
from dragmesh2_jax.runs.spec import method_spec

DAMPINGS = list(PAPER.dampings)


def ours(program: TrainProgram, epochs: int, seed: int):
    ts = init_jit(program, program.data(), seed_keys([seed])[0])
    for _ in range(epochs):
        ts, _ = epoch_jit(program, program.data(), ts)
    return program.controller(ts)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--object", default=str(default_object()))
    p.add_argument("--seeds", default="0,1,2")
    p.add_argument("--epochs", type=int, default=150)
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--out", default="results/brax_check")
    args = p.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    program = program_of(method_spec("state_only", args.object, backend="mujoco"))
    task = PAPER.task(program.task)
    rows = []
    for seed in [int(s) for s in parse_floats(args.seeds, "--seeds", minimum=0)]:
        for impl in ("ours", "brax"):
            path = out / f"{impl}_s{seed}.json"
            if path.is_file():
                rows.append(json.loads(path.read_text()))
                continue
            t0 = time.time()
            if impl == "ours":
                controller = ours(program, args.epochs, seed)
            else:
                controller, _ = train_brax_ppo(program.task, program.config, args.epochs, seed)
            seconds = time.time() - t0
            res = evaluate(task, controller, dataclasses.replace(PAPER, episodes=args.episodes, seed=seed))
            res.update(impl=impl, seed=seed, train_seconds=round(seconds, 1))
            atomic_write_json(path, res)
            rows.append(res)
            print(impl, seed, f"{seconds:.0f} s", [(c["mode"], c["damping"], c["success_rate"]) for c in res["cells"]],
                  flush=True)
    lines = ["| PPO | mode | " + " | ".join(f"x{d:g}" for d in DAMPINGS) + " | train s |", "|---" * 6 + "|"]
    for impl in ("ours", "brax"):
        rs = [r for r in rows if r["impl"] == impl]
        for mode in ("det", "stoch"):
            cells = []
            for d in DAMPINGS:
                v = np.array([c["success_rate"] for r in rs for c in r["cells"] if c["mode"] == mode
                              and c["damping"] == d])
                cells.append(f"{v.mean():.2f} ± {v.std(ddof=1) / np.sqrt(len(v)) if len(v) > 1 else 0:.2f}")
            secs = np.mean([r["train_seconds"] for r in rs])
            lines.append(f"| {impl} | {mode} | " + " | ".join(cells) + f" | {secs:.0f} |")
    table = "\n".join(lines)
    (out / "table.md").write_text(table + "\n")
    print(table)


if __name__ == "__main__":
    main()
