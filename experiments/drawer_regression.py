"""The drawer regression's mechanism, measured (RESULTS.md §1): for each palm placement of the generator that
passes its gate, how many hand geoms hold the handle in the state the task resets to, and what the *untrained*
policy (the paper's PICA at the reference's initialisation) does from there at x1: its first episodes' success,
detachment, length and final progress. A fingertip grasp leaves the first policies nothing to learn from.

    python experiments/drawer_regression.py --objects dragmesh2_jax/data/objects/drawer_cabinet_0213 \\
        dragmesh2_jax/data/objects/drawer_cabinet_0000 ../shared/gapartnet/45261 --seeds 0,1,2
"""

from __future__ import annotations

import argparse
import dataclasses
import json

import jax
import numpy as np

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.evaluation.rollout import cells, rollout
from dragmesh2_jax.io import atomic_write_json
from dragmesh2_jax.ppo.train import init_jit, make_train, policy_params, seed_keys
from dragmesh2_jax.runs.commands import parse_floats
from dragmesh2_jax.runs.spec import method_defaults
from dragmesh2_jax.scene import build_scene
from dragmesh2_jax.task.env import PullTask
from dragmesh2_jax.trajectory.generator import GeneratorParams, generate

WORLDS = 64  # the paper's batch: the first rollout of training
PICA = method_defaults("pica")


def first_episodes(task: PullTask, seeds: list[int]) -> list[dict]:
    """The untrained PICA policy's first episode in WORLDS worlds at x1 (stochastic, as training samples it)."""
    program = make_train(task, PICA.network, PICA.ppo, PICA.method)
    out = []
    for s in seeds:
        ts = init_jit(program, task.data, seed_keys([s])[0])
        r = rollout(task, program.make_policy(False), policy_params(ts), [1.0], WORLDS, seed=s)
        (cell,) = cells(r, [1.0], WORLDS)
        out.append({"seed": s, **{k: cell[k] for k in ("success_rate", "detach_rate", "steps_mean", "progress_mean",
                                                      "clip099")}})
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--objects", nargs="+", required=True)
    p.add_argument("--seeds", default="0,1,2")
    p.add_argument("--out", default="results/drawer_regression/placements.json")
    args = p.parse_args()
    seeds = [int(s) for s in parse_floats(args.seeds, "--seeds", minimum=0)]
    config = PICA.on("mujoco").task
    rows = []
    for folder in args.objects:
        obj = load_gapartnet(folder)
        scene = build_scene(obj)
        for k, placement in enumerate(GeneratorParams().placements):
            traj = generate(obj, dataclasses.replace(GeneratorParams(), placements=(placement,)), scene=scene)
            q = traj.header["quality"]
            row = {"object": obj.object_id, "placement": k, "passed": q["passed"], "grip": q["grip"],
                   "handle_contacts": q["handle_contacts"], "handle_force_n": q["handle_force_n"]}
            if q["passed"]:
                eps = first_episodes(PullTask(scene, traj, config), seeds)
                row["first_episodes"] = eps
                row["mean"] = {k: float(np.mean([e[k] for e in eps])) for k in eps[0] if k != "seed"}
            rows.append(row)
            print(json.dumps(row), flush=True)
    atomic_write_json(args.out, {"worlds": WORLDS, "seeds": seeds, "rows": rows, "jax": jax.__version__})


if __name__ == "__main__":
    main()
