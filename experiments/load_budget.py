"""Where a load-bounded policy spends its budget (issue 33): per damping, the share of control steps whose wrist
load is past the object's expert unit (``relative_load`` > 1: the expert drag's own peak at the world's damping,
from its exact grasp or the world's own start as the run's ``expert_load_unit`` says; the median over the cell's
starts in the table's header) and the mean excess past it, max(0, relative_load - 1), over the evaluation's
perturbed starts (deterministic), beside the expert drag replayed at its own pace from the same starts: what the
constraint asks of the policy against what the expert itself does. For a residual policy (``expert_prior``) also the
pull its own action adds over the expert's: its wrist translation u moves the hand's target residual_scale x alpha x u
from the drag's, about kp x residual_scale x alpha x |u| N at the translation drives' stiffness kp (the p95 over
episodes of each episode's peak, in N).

    python experiments/load_budget.py (--runs RUN [RUN ...] [--labels A B ...] | --object DIR [--unit start])
        [--episodes 16] [--damping 1,2,4,8] [--out budget.json]

Each RUN is a run folder of a method whose constraint reads ``relative_load`` (its checkpoint by its method's rule);
every run must be on the same object. With ``--object`` only the expert, on that object, in the unit ``--unit``.
Prints a markdown table (share past / mean excess / p95 of the episodes' peaks [/ the residual's pull p95, N]) and
writes the numbers as JSON."""

from __future__ import annotations

import argparse
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.baselines.tracking import tracking_controller
from dragmesh2_jax.evaluation.protocol import EvalProtocol
from dragmesh2_jax.evaluation.rollout import PEAK_PERCENTILE, rollout
from dragmesh2_jax.io import atomic_write_json
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.runs.commands import load_run
from dragmesh2_jax.task.config import EXPERT_UNITS, Constraint, RewardConfig
from dragmesh2_jax.task.expert import RELATIVE_LOAD, load_unit

#: A task that probes the expert's unit (any constraint on ``relative_load`` does; this one is never trained).
EXPERT_UNIT = RewardConfig(constraints=(Constraint(RELATIVE_LOAD, 1.0, "rate"),))


def spend(task, controller, dampings: list[float], episodes: int) -> list[dict]:
    """Per damping: the share of live steps past the unit, the mean excess past it, the first tenth of the
    episode's share of those steps (a start transient or a steady pull), the 95th percentile over episodes of each
    episode's peak (in units) and of the residual's pull (N; 0 for a policy that is not a residual)."""
    r = rollout(task, controller.make_policy(True), controller.params, dampings, episodes, 0, controller.controls,
                steps=task.config.episode_length, key=controller.key)
    scales = np.repeat(dampings, episodes)
    start = np.arange(len(scales)) % episodes % task.num_starts  # the start of world w (evaluation/rollout.py)
    units = np.asarray(jax.vmap(load_unit)(task.params.expert_load[start], jnp.asarray(scales, jnp.float32)))
    rel = r["wrist_load"] / units[None, :]
    c = task.config
    residual = c.expert_prior and controller.controls == "actions"  # the expert's replay sets targets, not actions
    reach = task.scene.config.hand.virtual.kp * c.residual_scale * c.alpha if residual else 0.0  # N per action unit
    pull = reach * np.linalg.norm(r["policy"][..., :3], axis=-1)
    early = np.arange(len(rel))[:, None] < c.episode_length // 10
    rows = []
    for d in dampings:
        cols = scales == d
        live, x = r["live"][:, cols], rel[:, cols]
        over = (x > 1.0) & live
        rows.append({"damping": d, "unit_n": float(np.median(units[cols])),
                     "rate": float(over.sum() / live.sum()),
                     "excess": float(np.where(live, np.maximum(x - 1.0, 0.0), 0.0).sum() / live.sum()),
                     "early_share": float((over & early).sum() / max(over.sum(), 1)),
                     "peak_p95": float(np.percentile(np.where(live, x, 0.0).max(axis=0), PEAK_PERCENTILE)),
                     "residual_pull_p95_n": float(np.percentile(np.where(live, pull[:, cols], 0.0).max(axis=0),
                                                                PEAK_PERCENTILE)),
                     "success": float(r["acc"]["success"][cols].mean())})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--runs", nargs="+")
    src.add_argument("--object")
    ap.add_argument("--unit", choices=EXPERT_UNITS, default="grasp", help="with --object: the expert's unit")
    ap.add_argument("--labels", nargs="+")
    ap.add_argument("--episodes", type=int, default=16)
    ap.add_argument("--damping", default="1,2,4,8")
    ap.add_argument("--out", default="budget.json")
    a = ap.parse_args(argv)
    dampings = [float(d) for d in a.damping.split(",")]
    protocol = EvalProtocol(dampings=tuple(dampings), modes=("det",), episodes=a.episodes)
    table, task = {}, None
    if a.object:
        task = protocol.task(load_task(a.object, None, backend="mujoco", reward=EXPERT_UNIT,
                                       expert_load_unit=a.unit), costs=True)
    for label, folder in zip(a.labels or [Path(r).name for r in a.runs or ()], a.runs or (), strict=True):
        program, ts, _, _ = load_run(folder)
        task = protocol.task(program.task, costs=True)
        table[label] = spend(task, program.controller(ts), dampings, a.episodes)
    table["expert (its own pace)"] = spend(task, tracking_controller(task), dampings, a.episodes)
    print(f"{task.object_id}: share of steps past the expert's peak / mean excess past it / p95 of the episodes' "
          f"peaks in its units (det, {a.episodes} perturbed starts per damping)\n")
    units = table["expert (its own pace)"]
    print("| | " + " | ".join(f"x{d:g} ({r['unit_n']:.0f} N)" for d, r in zip(dampings, units, strict=True)) + " |")
    print("|---" * (len(dampings) + 1) + "|")
    for label, rows in table.items():
        cells = ["{rate:.2f} / {excess:.3f} / {peak_p95:.2f}".format(**r)
                 + (f" / {r['residual_pull_p95_n']:.0f} N" if r["residual_pull_p95_n"] else "") for r in rows]
        print(f"| {label} | " + " | ".join(cells) + " |")
    atomic_write_json(a.out, {"object_id": task.object_id, "episodes": a.episodes, "rows": table})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
