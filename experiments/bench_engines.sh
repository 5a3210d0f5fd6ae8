#!/usr/bin/env bash
# The CPU figures of issue 22 (RESULTS.md §4), side by side in one run on one machine:
#   the three engines' physics at 1/16/64 worlds, MJX-JAX with and without the contact budget, and PPO training
#   on each engine. Writes JSON rows under results/speed/ (or $OUT).
set -uo pipefail
out="${OUT:-results/speed}"
mkdir -p "$out"
dm() { python3 -m dragmesh2_jax.cli "$@"; }
dm bench env --backend mujoco,mjx --impl jax,warp --num-envs 1,16,64 --steps 50 --mjx-steps 10 --json \
  > "$out/bench_env_engines.json"
python3 - "$out/bench_env_mjx_budget.json" <<'PY'
# MJX-JAX at 16 worlds with the probe's contact budget and with every candidate contact kept (no cap)
import json, sys
from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.bench import bench_env
from dragmesh2_jax.runs.build import load_task
rows = []
for contacts in (None, 10_000):
    task = load_task(str(default_object()), None, "mjx", "jax", contacts=contacts)
    rows.append({**bench_env(task, 16, 10), "cap": "budget" if contacts is None else "none"})
    print(rows[-1]["cap"], rows[-1]["contact_slots"], rows[-1]["constraint_rows"], rows[-1]["compile_s"],
          rows[-1]["physics_steps_per_s"], file=sys.stderr)
json.dump(rows, open(sys.argv[1], "w"), indent=1)
PY
dm bench train --backend mujoco --num-envs 64 --epochs 5 --json > "$out/bench_train_mujoco.json"
for impl in jax warp; do
  dm bench train --backend mjx --impl "$impl" --num-envs 16 --epochs 2 --json > "$out/bench_train_mjx_$impl.json"
done
