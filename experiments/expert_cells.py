"""A method's expert alone: its task built as a run of the method would build it (grasp, contacts, finger drives),
the expert drag replayed as PD targets from the evaluation's perturbed starts (``--prior``: instead the residual
method's prior, its residual at zero), x1 and x8 by default (det, 50 starts per cell), one line per object: success,
x1 wrist load p95, penetration p95 (each episode's deepest contact) and its settled recount, the settled palm p95.

    python experiments/expert_cells.py METHOD OBJECT [OBJECT ...] [--prior] [--override task.grip_closure=0.2 ...]"""

from __future__ import annotations

import argparse
import json
import sys

from dragmesh2_jax.baselines.tracking import prior_controller, tracking_controller
from dragmesh2_jax.evaluation.evaluate import evaluate
from dragmesh2_jax.evaluation.protocol import EvalProtocol
from dragmesh2_jax.runs.build import tasks_of
from dragmesh2_jax.runs.spec import method_spec


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("method")
    ap.add_argument("objects", nargs="+")
    ap.add_argument("--override", action="append", default=[], help="GROUP.FIELD=JSON (task or scene)")
    ap.add_argument("--damping", default="1,8")
    ap.add_argument("--prior", action="store_true", help="the residual method's prior alone instead of the replay")
    a = ap.parse_args(argv)
    groups: dict[str, dict] = {"task": {}, "scene": {}}
    for o in a.override:
        key, value = o.split("=", 1)
        group, field = key.split(".", 1)
        groups[group][field] = json.loads(value)
    protocol = EvalProtocol(dampings=tuple(float(d) for d in a.damping.split(",")), modes=("det",), episodes=50)
    for obj in a.objects:
        spec = method_spec(a.method, obj, backend="mujoco", task=groups["task"], scene=groups["scene"])
        (task,) = tasks_of(spec)
        task = protocol.task(task)
        cells = evaluate(task, (prior_controller if a.prior else tracking_controller)(task), protocol)["cells"]
        print(obj, " ".join(a.override), "; ".join(
            f"x{c['damping']:g} {c['success_rate']:.2f}, {c['wrist_load_peak_n']:.0f} N, "
            f"{c['penetration_p95_mm']:.1f} mm ({c['penetration_settled_p95_mm']:.1f}), "
            f"palm {c['palm_speed_settled_peak_m_s']:.2f}" for c in cells),
            flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
