"""Which way does a policy pull first? Its wrist translation over its first control steps against the expert drag's
over the expert's first steps, as the cosine between the two (1: along the expert's opening direction, 0: across
it), per perturbed start, and how far the part moved; deterministic actions, x1.

    python experiments/pull_direction.py runs/generalist_s0/checkpoints/final ../shared/gapartnet/45780 ...

The diagnosis behind RESULTS.md §6e: on the real doors the generalist pulled across the opening direction.
"""

from __future__ import annotations

import argparse

import numpy as np

from dragmesh2_jax.baselines.tracking import tracking_controller
from dragmesh2_jax.evaluation.rollout import rollout
from dragmesh2_jax.runs.commands import load_run


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("checkpoint")
    p.add_argument("objects", nargs="+")
    p.add_argument("--policy-steps", type=int, default=4)
    p.add_argument("--expert-steps", type=int, default=120, help="the expert drag is slow: its first 2 s")
    p.add_argument("--starts", type=int, default=8)
    args = p.parse_args()
    for obj in args.objects:
        program, ts, _, _ = load_run(args.checkpoint, "mujoco", object_dir=obj)
        task, c = program.task, program.controller(ts)
        pol = rollout(task, c.make_policy(True), c.params, [1.0], episodes=args.starts, steps=args.policy_steps + 1,
                      key=c.key)
        t = tracking_controller(task)
        exp = rollout(task, t.make_policy(True), t.params, [1.0], controls=t.controls, steps=args.expert_steps + 1,
                      key=t.key)
        e = exp["hand_q"][-1, 0, :3] - exp["hand_q"][0, 0, :3]
        d = pol["hand_q"][args.policy_steps, :, :3] - pol["hand_q"][0, :, :3]
        cos = d @ e / np.maximum(np.linalg.norm(d, axis=1) * np.linalg.norm(e), 1e-12)
        dq = pol["obj_q"][args.policy_steps] - pol["obj_q"][0]  # both recorded before each step
        print(f"{obj}: cosine {cos.mean():.2f} (per start {', '.join(f'{x:.2f}' for x in cos)}), wrist moved "
              f"{np.linalg.norm(d, axis=1).mean() * 100:.1f} cm in {args.policy_steps} steps (the expert "
              f"{np.linalg.norm(e) * 100:.1f} cm in {args.expert_steps}), part moved {dq.mean():.3f}", flush=True)


if __name__ == "__main__":
    main()
