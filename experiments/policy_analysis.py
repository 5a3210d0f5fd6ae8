"""How does a trained policy lose the handle? Per damping: which action channels saturate (wrist translation,
wrist rotation, active fingers, locked axes), how fast the palm moves, how hard the arm pulls, where and under
which load the grip is lost, from the evaluation's perturbed starts (det mode).

    python experiments/policy_analysis.py --runs runs/sweep_val/45780/pica_s0 --damping 1,2,4 --episodes 8
"""

from __future__ import annotations

import argparse
import json

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.assets.hand import NUM_VIRTUAL, active_dofs
from dragmesh2_jax.evaluation.protocol import PAPER
from dragmesh2_jax.io import atomic_write_json
from dragmesh2_jax.ppo.train import policy_params
from dragmesh2_jax.runs.commands import load_run, parse_floats
from dragmesh2_jax.task.protocol import CLIP_LEVEL

LOSS_WINDOW = 10  # control steps before a detachment read as the way the handle was lost
GROUPS = {"wrist_translation": np.arange(3), "wrist_rotation": np.arange(3, NUM_VIRTUAL)}


def _mean(values: list) -> float | None:
    return float(np.mean(values)) if values else None


def analyse(run: str, dampings: list[float], episodes: int, backend: str) -> list[dict]:
    program, ts, _, ck = load_run(run, backend)
    task = PAPER.task(program.task)
    policy, params = program.make_policy(True), policy_params(ts)
    active = active_dofs()
    groups = {**GROUPS, "fingers_active": np.flatnonzero(active[NUM_VIRTUAL:]) + NUM_VIRTUAL,
              "locked": np.flatnonzero(~active)}
    n = len(dampings) * episodes
    scales = jnp.asarray(np.repeat(dampings, episodes), jnp.float32)
    reset, step = jax.vmap(task.reset), jax.vmap(task.step)
    T = task.config.episode_length

    @jax.jit
    def roll(params, key):
        state = reset(jax.random.split(key, n), scales)

        def body(carry, _):
            state, live = carry
            a = jnp.clip(policy(params, state.obs, key), -1, 1)
            k0 = jax.vmap(task.kinematics)(state)
            state = step(state, a)
            k = jax.vmap(task.kinematics)(state)
            speed = jnp.linalg.norm(k.palm - k0.palm, axis=-1) / task.config.control_dt
            out = (a, speed, jnp.linalg.norm(k.force[:, :3], axis=-1), state.metrics["palm_dist"], live,
                   state.metrics["success"], state.metrics["detach"], state.metrics["progress"])
            return (state, live & ~state.done), out

        return jax.lax.scan(body, (state, jnp.ones(n, bool)), None, length=T)[1]

    a, speed, wrist, dist, live, success, detach, progress = jax.device_get(roll(params, jax.random.PRNGKey(0)))
    lost = (detach * live) > 0  # (T, n): the step each detaching episode lost the handle
    rows = []
    for i, d in enumerate(dampings):
        sl = slice(i * episodes, (i + 1) * episodes)
        lv = live[:, sl]
        lost_at = [(int(np.argmax(lost[:, j])), j) for j in range(sl.start, sl.stop) if lost[:, j].any()]
        sat = {g: float((np.abs(a[:, sl][..., idx]).max(-1) > CLIP_LEVEL)[lv].mean()) for g, idx in groups.items()}
        rows.append({
            "run": str(run), "checkpoint": ck.name, "object": task.scene.obj.object_id, "damping": d,
            "success_rate": float((success[:, sl] * lv).max(0).mean()),
            "detach_rate": float((detach[:, sl] * lv).max(0).mean()),
            "steps_mean": float(lv.sum(0).mean()), **{f"sat_{g}": v for g, v in sat.items()},
            "palm_speed_mean_m_s": float(speed[:, sl][lv].mean()),
            "wrist_force_mean_N": float(wrist[:, sl][lv].mean()), "wrist_force_peak_N": float(wrist[:, sl][lv].max()),
            "palm_dist_max_m": float(dist[:, sl][lv].max()),
            # how the detaching episodes lost the handle: how far the part had come, and the wrist load over the
            # last LOSS_WINDOW steps (an overload peaks near what the grasp holds; a slip does not)
            "detach_progress_mean": _mean([progress[t, j] for t, j in lost_at]),
            "detach_load_peak_N": _mean([wrist[max(t - LOSS_WINDOW, 0):t + 1, j].max() for t, j in lost_at]),
        })
    return rows


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--runs", nargs="+", required=True)
    p.add_argument("--damping", default="1,2,4")
    p.add_argument("--episodes", type=int, default=8)
    p.add_argument("--backend", default="mujoco")
    p.add_argument("--out", default="results/policy_analysis.json")
    args = p.parse_args()
    rows = [r for run in args.runs for r in analyse(run, parse_floats(args.damping, "--damping", 0.0),
                                                    args.episodes, args.backend)]
    keys = ("damping", "success_rate", "detach_rate", "steps_mean", "sat_wrist_translation", "sat_wrist_rotation",
            "sat_fingers_active", "sat_locked", "palm_speed_mean_m_s", "wrist_force_mean_N", "wrist_force_peak_N",
            "detach_progress_mean", "detach_load_peak_N")
    print("run | " + " | ".join(keys))
    for r in rows:
        print(r["run"].split("/")[-1] + " | " + " | ".join("-" if r[k] is None else f"{r[k]:.2f}" for k in keys))
    atomic_write_json(args.out, rows)
    print(json.dumps({"written": args.out}))


if __name__ == "__main__":
    main()
