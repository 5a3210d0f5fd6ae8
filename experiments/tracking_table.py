"""Tracking-baseline table (paper Table 2, row 1): success and final progress per object and damping.

    python experiments/tracking_table.py --objects ../shared/gapartnet/* --damping 1,2,4,8 --backend mujoco
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.evaluate import track
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.runs.commands import parse_floats


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--objects", nargs="+", required=True)
    p.add_argument("--damping", default="1,2,4")
    p.add_argument("--backend", default="mujoco")
    args = p.parse_args()
    dampings = parse_floats(args.damping, "--damping")
    print("| object | category | joint | gate | " + " | ".join(f"x{d:g}" for d in dampings) + " | s |")
    print("|" + "---|" * (len(dampings) + 5))
    for obj in args.objects:
        t0 = time.time()
        try:
            task = load_task(obj, None, backend=args.backend)
        except DragMeshError as e:
            print(f"| {Path(obj).name} | error: {e} |")
            continue
        rows = track(task, dampings)
        q = task.traj.header["quality"]
        cells = " | ".join(f"{r['success_rate']:.0f} ({r['progress_mean']:.2f})" for r in rows)
        jt = "revolute" if task.scene.ids.target_is_revolute else "prismatic"
        print(f"| {Path(obj).name} | {task.scene.obj.category} | {jt} | {'pass' if q['passed'] else 'FAIL'} | "
              f"{cells} | {time.time() - t0:.1f} |")


if __name__ == "__main__":
    main()
