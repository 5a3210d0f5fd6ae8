"""A pace that yields, measured on the expert drag itself (issue "Hold on and follow", item 2): the recipe's expert
replayed time-indexed (today's prior) against the same drag whose target may run at most LEAD of the part's range
ahead of where the part is (the drag's step capped at the first whose planned part position is LEAD past the part's
progress now), from the evaluation's perturbed starts at x1-x16. The hand's target then waits for a door that lags
instead of running ahead of it, the cause of the palm's speed-up under load (the target far ahead, the hand snaps on
when the door gives). Per object, lead and damping: det success, the wrist load p95 and the palm speed p95.

    python experiments/yielding_drag.py --objects DIR [DIR ...] [--leads inf,0.2,0.1,0.05] [--episodes 50]
        [--interface targets|actions] [--out results/pace/yielding.jsonl]

The expert is the recipe's (its grasp and placement: ``--task.expert-grasp seated --task.expert-placement holds``).
``--interface actions`` sends the drag through the action bound as the recipe's prior does (a = clip((target - q) /
alpha, -1, 1): the hand's PD target at most alpha from the hand), ``targets`` (the default) sets the PD target itself,
as the tracking baseline and ``envelope`` do."""

from __future__ import annotations

import argparse
import functools
import json
import math
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.baselines.tracking import drag_targets, toward
from dragmesh2_jax.evaluation.evaluate import evaluate
from dragmesh2_jax.evaluation.protocol import EvalProtocol
from dragmesh2_jax.io import atomic_write_text
from dragmesh2_jax.policies.controller import Controller
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.runs.overrides import RECIPE_DAMPINGS
from dragmesh2_jax.runs.spec import method_defaults
from dragmesh2_jax.task.observation import STATE_SIZE

#: Where the part's progress p_t sits in the paper's s_t (task/observation.paper_state): it ends with phi =
#: [p_t, (q_done - q) / Delta, Delta].
PROGRESS = STATE_SIZE - 3


def yielding(params, obs, key):
    """The drag's target of step min(t, the first step whose planned progress is LEAD past the part's now)."""
    targets, planned, lead = params
    cap = jnp.searchsorted(planned, obs.state[..., PROGRESS] + lead, side="right")
    return targets[jnp.minimum(jnp.minimum(obs.step, cap), targets.shape[0] - 1)]


def yielding_actions(alpha: float, params, obs, key):
    """:func:`yielding`'s target through the action bound, as the residual's prior is."""
    return toward(alpha, yielding(params, obs, key), obs)


def controller(task, lead: float, interface: str = "targets") -> Controller:
    targets = drag_targets(task)
    steps = len(targets)
    schedule = task.traj.drag_schedule(task.config.control_dt, steps)
    planned = (schedule - task.traj.q_start) / max(task.traj.q_goal - task.traj.q_start, 1e-6)
    planned = np.maximum.accumulate(planned).astype(np.float32)  # searchsorted needs it sorted
    policy = yielding if interface == "targets" else functools.partial(yielding_actions, task.config.alpha)
    return Controller(f"yielding_{lead:g}", lambda deterministic: policy,
                      (jnp.asarray(targets), jnp.asarray(planned), jnp.float32(min(lead, 1e6))), controls=interface,
                      key=("yielding", interface))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", nargs="+", required=True)
    ap.add_argument("--leads", default="inf,0.2,0.1,0.05")
    ap.add_argument("--episodes", type=int, default=50)
    ap.add_argument("--interface", choices=("targets", "actions"), default="targets")
    ap.add_argument("--out", default="results/pace/yielding.jsonl")
    a = ap.parse_args(argv)
    protocol = EvalProtocol(dampings=RECIPE_DAMPINGS, modes=("det",), episodes=a.episodes)
    recipe = method_defaults("recommended").task  # its expert's grasp and placement
    rows = []
    for folder in a.objects:
        task = load_task(folder, None, backend="mujoco", expert_grasp=recipe.expert_grasp,
                         expert_placement=recipe.expert_placement)
        seated = task.traj.header["generator"]["seated"]
        for lead in (float(x) for x in a.leads.split(",")):
            for c in evaluate(protocol.task(task), controller(task, lead, a.interface), protocol)["cells"]:
                rows.append({"object": Path(folder).name, "seated": seated, "interface": a.interface,
                             "lead": lead if math.isfinite(lead) else "inf",
                             **{k: c[k] for k in ("damping", "success_rate", "wrist_load_peak_n", "palm_speed_peak_m_s",
                                                  "steps_mean")}})
                r = rows[-1]
                print(f"{r['object']} lead {r['lead']} x{r['damping']:g}: {r['success_rate']:.2f}, "
                      f"{r['wrist_load_peak_n']:.0f} N, palm {r['palm_speed_peak_m_s']:.2f} m/s, "
                      f"{r['steps_mean']:.0f} steps", flush=True)
    atomic_write_text(a.out, "".join(json.dumps(r) + "\n" for r in rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
