"""Why do policies saturate and detach? The holding envelope of the hand, measured with scripted pulls.

The expert drag (the tracking baseline's hand targets) is replayed ``speed`` times faster (every ``speed``-th
target), at each damping multiplier, from the exact expert grasp. Per (speed, damping): success, the peak and
mean pulling load on the wrist (force sensor, N), the peak normal force on the fingers (touch sensors, N), the
fraction of finger-actuator steps at their force limit, and the palm-handle distance at the end.

    python experiments/failure_analysis.py --objects ../shared/gapartnet/45661 --speeds 1,2,4,8,16 \\
        --damping 1,2,4,8 --out results/failure_analysis.json
"""

from __future__ import annotations

import argparse
import json

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.assets.hand import NUM_VIRTUAL
from dragmesh2_jax.baselines.tracking import drag_targets
from dragmesh2_jax.io import atomic_write_json
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.runs.commands import parse_floats


def envelope(task, speeds: list[int], dampings: list[float]) -> list[dict]:
    base = drag_targets(task)
    m = task.scene.model
    finger_limit = float(m.actuator_forcerange[task.scene.ids.hand_actuators[NUM_VIRTUAL], 1])
    rows = []
    n = len(dampings)
    for speed in speeds:
        targets = jnp.asarray(base[speed - 1::speed])
        keys = jax.random.split(jax.random.PRNGKey(0), n)

        @jax.jit
        def run(keys, scales, targets=targets):
            state = jax.vmap(task.reset)(keys, jnp.asarray(scales, jnp.float32))

            def body(carry, target):
                state, finished, success = carry
                state = jax.vmap(task.step_target)(state, jnp.broadcast_to(target, (n, 51)))
                k = jax.vmap(task.kinematics)(state)
                live = ~finished
                success = success | (live & (state.metrics["success"] > 0))
                finished = finished | state.done
                return (state, finished, success), (k.force, state.metrics["palm_dist"], live)

            init = (state, jnp.zeros(n, bool), jnp.zeros(n, bool))
            (_, _, success), trace = jax.lax.scan(body, init, targets)
            return success, trace

        success, (force, dist, live) = jax.device_get(run(keys, dampings))
        wrist = np.linalg.norm(force[..., 0:3], axis=-1)  # (T, n)
        touch = force[..., 6:]
        for i, d in enumerate(dampings):
            lv = live[:, i]
            rows.append({
                "object": task.scene.obj.object_id, "speed": speed, "damping": d, "success": bool(success[i]),
                "steps": int(lv.sum()), "wrist_force_peak_N": float(wrist[lv, i].max()),
                "wrist_force_mean_N": float(wrist[lv, i].mean()),
                "finger_touch_peak_N": float(touch[lv, i, 1:].max()), "palm_touch_peak_N": float(touch[lv, i, 0].max()),
                "final_palm_dist_m": float(dist[lv, i][-1]), "finger_limit_Nm": finger_limit,
            })
    return rows


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--objects", nargs="+", required=True)
    p.add_argument("--speeds", default="1,2,4,8,16")
    p.add_argument("--damping", default="1,2,4,8")
    p.add_argument("--backend", default="mujoco")
    p.add_argument("--out", default="results/failure_analysis.json")
    args = p.parse_args()
    speeds = [int(s) for s in parse_floats(args.speeds, "--speeds", minimum=1)]
    dampings = parse_floats(args.damping, "--damping", minimum=0.0)
    rows = []
    for obj in args.objects:
        task = load_task(obj, None, backend=args.backend)
        rows += envelope(task, speeds, dampings)
        print(f"{'object':>8} {'speed':>5} {'damp':>5} {'ok':>3} {'steps':>5} {'wristF pk':>9} {'mean':>6} "
              f"{'finger pk':>9} {'palm pk':>8} {'final d':>7}")
        for r in rows[-len(speeds) * len(dampings):]:
            print(f"{r['object']:>8} {r['speed']:5d} {r['damping']:5g} {int(r['success']):3d} {r['steps']:5d} "
                  f"{r['wrist_force_peak_N']:9.1f} {r['wrist_force_mean_N']:6.1f} {r['finger_touch_peak_N']:9.1f} "
                  f"{r['palm_touch_peak_N']:8.1f} {r['final_palm_dist_m']:7.3f}")
    atomic_write_json(args.out, rows)
    print(json.dumps({"written": args.out}))


if __name__ == "__main__":
    main()
