"""How deep is each candidate grasp from many starts and under load? The starts choice (``task/choice.py``) ranks
a run's candidate grasps by their deepest contact at x1 over its 8 clear starts; the adoption rule reads penetration
p95 over 50 starts at x1-x8. Here the run's candidates that the choice found holding the part at ``--min-held`` are
replayed as the choice replays them from ``--starts`` clear starts of the run's own noise at each ``--damping``: per
candidate and damping, the share opened and the deepest contact's p95 and maximum over the starts.

    python experiments/choice_depth.py RUN --starts 24 --damping 1,8 --min-held 8

A diagnostic, not a judged run.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace

import numpy as np

from dragmesh2_jax.physics import contacts
from dragmesh2_jax.runs.commands import load_run, parse_floats
from dragmesh2_jax.scene import build_scene
from dragmesh2_jax.task.choice import from_part
from dragmesh2_jax.task.config import ResetNoise
from dragmesh2_jax.task.env import substeps_of
from dragmesh2_jax.task.expert import reachable_targets
from dragmesh2_jax.task.load import generator_params, plan_scene_config
from dragmesh2_jax.task.starts import reset_starts
from dragmesh2_jax.trajectory.generator import generate


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run")
    p.add_argument("--starts", type=int, default=24)
    p.add_argument("--seed", type=int, default=42)
    p.add_argument("--damping", default="1,8")
    p.add_argument("--min-held", type=float, default=8.0)
    args = p.parse_args()
    program, _, _, _ = load_run(args.run, "mujoco")
    task = program.task
    scene, config = task.scene, task.config
    choice = task.traj.header["generator"]["choice"]
    params = generator_params(config)
    other = build_scene(scene.obj, plan_scene_config(config, scene.config))
    physics = {scene.config.object_contact: scene, other.config.object_contact: other}
    noise = replace(config.reset_noise or ResetNoise(), bank=args.starts, seed=args.seed)
    for i, s in enumerate(choice["scores"]):
        if s["held"] < args.min_held:
            continue
        placement = next(pl for pl in params.placements if all(
            getattr(pl, k) == v for k, v in s["placement"].items()))
        traj = generate(scene.obj, replace(params, placements=(placement,)), scene=physics[s["planned_in"]])
        targets = reachable_targets(scene, traj, config)
        schedule = traj.drag_schedule(config.control_dt, config.episode_length)
        until = traj.q_done_at(config.rho)
        starts = reset_starts(scene, traj, noise)
        for damping in parse_floats(args.damping, "--damping", 0.0):
            runs = [contacts.replay(scene, st, from_part(targets, schedule, st[1]), substeps_of(scene, config),
                                    config.settle_substeps, until, damping) for st in starts]
            deep = 1000 * np.array([r.deepest for r in runs])
            print(json.dumps({"run": args.run, "candidate": i, "kept": i == choice["kept"], **s, "damping": damping,
                              "starts": len(runs), "opened": float(np.mean([r.steps is not None for r in runs])),
                              "deepest_p95_mm": round(float(np.percentile(deep, 95)), 3),
                              "deepest_max_mm": round(float(deep.max()), 3)}), flush=True)


if __name__ == "__main__":
    main()
