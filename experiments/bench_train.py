"""Training throughput of PICA: seconds per epoch and env steps/s at several batch sizes.

    python experiments/bench_train.py --num-envs 64,1024 --backend mujoco --epochs 2
"""

from __future__ import annotations

import argparse
import json
import time

import jax

from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.bench import machine
from dragmesh2_jax.runs import make_trainer


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--object", default=str(default_object()))
    p.add_argument("--num-envs", default="64,1024")
    p.add_argument("--epochs", type=int, default=2, help="timed epochs after the compiling one")
    p.add_argument("--method", default="pica")
    p.add_argument("--backend", default="auto")
    args = p.parse_args()
    for n in (int(x) for x in args.num_envs.split(",")):
        trainer = make_trainer(args.object, None, args.method, args.backend, "jax", num_envs=n)
        ts = trainer.init()
        t0 = time.perf_counter()
        ts, m = trainer.epoch(ts)
        jax.block_until_ready(ts)
        first = time.perf_counter() - t0
        t0 = time.perf_counter()
        for _ in range(args.epochs):
            ts, m = trainer.epoch(ts)
        jax.block_until_ready(ts)
        per = (time.perf_counter() - t0) / args.epochs
        steps = n * trainer.config.rollout_len
        print(json.dumps({"method": args.method, "backend": trainer.task.backend.name, "num_envs": n,
                          "first_epoch_s (compile)": round(first, 2), "s_per_epoch": round(per, 3),
                          "env_steps_per_s": round(steps / per, 1), "physics_steps_per_s": round(
                              steps * trainer.task.substeps / per, 1),
                          "paper_budget_s (150 epochs x 64 envs)": round(150 * per, 1) if n == 64 else None,
                          **machine()}))


if __name__ == "__main__":
    main()
