#!/usr/bin/env bash
# Issue 21: does a batch that mixes objects step as fast as one object's? The C engine at 64 worlds (the PPO batch),
# the packaged drawer alone against the four packaged objects mixed in one batch (drawer, heavy drawer, door cabinet,
# dishwasher: each world steps one), alternately for ROUNDS rounds so that a noisy CPU weighs on both alike.
# Writes results/speed/bench_env_mix.json (or $OUT/$NAME) and prints the physics steps/s of each round and their ratio.
# OBJECTS (comma-separated folders) mixes those instead, e.g. the generalist's training objects (issue 36).
set -euo pipefail
out="${OUT:-results/speed}"
rounds="${ROUNDS:-3}"
mkdir -p "$out"
objs="${OBJECTS:-$(python3 -c "from dragmesh2_jax.assets.procedural import default_objects; print(','.join(map(str, default_objects())))")}"
one=$(python3 -c "from dragmesh2_jax.assets.procedural import default_object; print(default_object())")
tmp=$(mktemp -d)
for r in $(seq "$rounds"); do
  for which in one mix; do
    [ "$which" = one ] && o="$one" || o="$objs"
    python3 -m dragmesh2_jax.cli bench env --backend mujoco --num-envs 64 --steps 100 --object "$o" --json \
      > "$tmp/${which}_$r.json"
  done
done
python3 - "$tmp" "$rounds" "$out/${NAME:-bench_env_mix.json}" <<'PY'
import json, statistics, sys
from pathlib import Path
from dragmesh2_jax.io import atomic_write_json
tmp, rounds, dest = Path(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
rows = {w: [json.loads((tmp / f"{w}_{r}.json").read_text())[0] for r in range(1, rounds + 1)] for w in ("one", "mix")}
ratios = [m["physics_steps_per_s"] / o["physics_steps_per_s"] for o, m in zip(rows["one"], rows["mix"])]
for r, (o, m, q) in enumerate(zip(rows["one"], rows["mix"], ratios), 1):
    print(f"round {r}: one object {o['physics_steps_per_s']:9.0f}/s  {m['objects']} objects mixed "
          f"{m['physics_steps_per_s']:9.0f}/s  ratio {q:.2f}")
print(f"median ratio mixed/one: {statistics.median(ratios):.2f}")
atomic_write_json(dest, {"rows": rows, "ratios": ratios})
PY
rm -rf "$tmp"
