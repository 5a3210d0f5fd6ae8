#!/usr/bin/env bash
# The GPU figures of RESULTS.md §4 for both MJX implementations, in one call on a lent device.
# The device's image has JAX with CUDA, flax, optax, orbax, scipy and numpy; the rest travels as Python 3.12 wheels:
#   here:   pip download --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
#             --platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 --platform manylinux_2_17_x86_64 \
#             -d .whl mujoco==3.17.0 mujoco-mjx==3.17.0 warp-lang==1.18.0 glfw pyopengl trimesh coacd defusedxml \
#             tyro docstring-parser typeguard shtab tensorboardX
#           experiments/wheel_parts.sh split .whl 48        # warp-lang (~149 MB) into parts that fit one transfer
#           mkdir .whl/base && mv .whl/*.whl .whl/base       # the rest as one carried path (a call carries 8)
#   device: one call carrying .whl/base, one per part (ignored files stay on a warm machine between calls: 30 s), the
#           last (the part's .sha256 beside it) running  GPU_BUDGET_S=<seconds> bash experiments/gpu_figures.sh
#   (2026-12-04: the project's tree is 13 MiB of a call's 64 MiB, so a part of 48 MiB fits)
# Steps run most important first; a step starts only while GPU_BUDGET_S leaves it its minimum, and each is cut at
# the deadline, so a short lease still brings back what finished. A device call returns at most 8 files: every
# step's JSON lands in one file, $OUT/rows.json ({step: rows}), rewritten after each step; steps.log says what ran.
set -uo pipefail
out="${OUT:-out/gpu}"
budget="${GPU_BUDGET_S:-540}"
mkdir -p "$out"
export PYTHONUNBUFFERED=1
if [ -d .whl ]; then
  bash experiments/wheel_parts.sh join .whl || exit 2
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site \
    $(find .whl -type f -name '*.whl')
  export PYTHONPATH=/tmp/site:$PWD
fi
rows=/tmp/gpu_rows
mkdir -p "$rows"
{ nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv
  python3 -m pip list 2>/dev/null | grep -iE '^(jax|jaxlib|flax|optax|orbax|numpy|scipy|mujoco|warp)'
} > "$out/gpu.txt" 2>&1

collect() {
  python3 - "$rows" "$out/rows.json" <<'EOF'
import json, pathlib, sys
rows = {}
for f in sorted(pathlib.Path(sys.argv[1]).glob("*.json")):
    text = f.read_text().strip()
    try:
        rows[f.stem] = json.loads(text) if text else None
    except json.JSONDecodeError:
        rows[f.stem] = text
tmp = pathlib.Path(sys.argv[2] + ".tmp")
tmp.write_text(json.dumps(rows, indent=1))
tmp.replace(sys.argv[2])
EOF
}

n=0
step() {  # step NAME MIN_S ARGS...: one `dragmesh2` command, its stdout the step's rows
  local name=$1 need=$2; shift 2
  local left=$((budget - SECONDS)) t0=$SECONDS
  n=$((n + 1))
  if [ "$left" -lt "$need" ]; then echo "$name: skipped ($left s left)" >> "$out/steps.log"; return; fi
  timeout "$left" python3 -m dragmesh2_jax.cli "$@" > "$rows/$(printf %02d $n)_$name.json" 2>> "$out/stderr.log"
  echo "$name: rc=$? $((SECONDS - t0)) s" >> "$out/steps.log"
  collect
}

pystep() {  # pystep NAME MIN_S SCRIPT ARGS...: an experiment that writes the step's rows to its --out
  local name=$1 need=$2 script=$3; shift 3
  local left=$((budget - SECONDS)) t0=$SECONDS
  n=$((n + 1))
  if [ "$left" -lt "$need" ]; then echo "$name: skipped ($left s left)" >> "$out/steps.log"; return; fi
  timeout "$left" python3 "$script" "$@" --out "$rows/$(printf %02d $n)_$name.json" >> "$out/steps.log" 2>> "$out/stderr.log"
  echo "$name: rc=$? $((SECONDS - t0)) s" >> "$out/steps.log"
  collect
}

mjx=(--backend mjx --json)
# physics throughput of the full hand task at 4096 worlds, both implementations (target: >= 1e6 physics steps/s)
step env_warp_4096 60 bench env "${mjx[@]}" --impl warp --num-envs 4096 --steps 50
step env_jax_4096 90 bench env "${mjx[@]}" --impl jax --num-envs 4096 --steps 50
# PICA training at 4096 envs
step train_warp_4096 90 bench train "${mjx[@]}" --impl warp --num-envs 4096
step train_jax_4096 120 bench train "${mjx[@]}" --impl jax --num-envs 4096
# the scaling of the physics in worlds (Warp's kernels are compiled by now)
step env_warp_sizes 40 bench env "${mjx[@]}" --impl warp --num-envs 1024,8192 --steps 50
# the paper's per-object budget (150 epochs x 64 envs x 32 steps), compile included: budget_s
step train_jax_64 90 bench train "${mjx[@]}" --impl jax --num-envs 64
step train_warp_64 60 bench train "${mjx[@]}" --impl warp --num-envs 64
# a seed-vmapped column of 3 runs
step train_warp_1024_runs 90 bench train "${mjx[@]}" --impl warp --num-envs 1024 --runs 1,3
step env_jax_sizes 150 bench env "${mjx[@]}" --impl jax --num-envs 1024,8192 --steps 50
# issue 56: a batch that mixes every category on the one-structure template against one object, then the generalist's
# 10 M env steps on MJX-Warp over its mix (its 40 objects built first; the step's seconds in steps.log, the run's log
# rows with compile and training time in its folder's summary line)
pystep mixed_env 120 experiments/mixed_structure_speed.py --rounds 3 \
  --engines mjx-warp:1024:50,mjx-warp:4096:50,mjx-warp:8192:50,mjx-jax:4096:50
step generalist_warp 300 train --generalist --backend mjx --impl warp --out /tmp/generalist_gpu --quiet
echo "done in $SECONDS s" >> "$out/steps.log"
