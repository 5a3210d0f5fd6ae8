#!/usr/bin/env bash
# The GPU figures of issue 10, ready to run on a lent device (see RESULTS.md §8):
#   here:        ../shared/tools/gpu_wheels.sh            # wheels the GPU image lacks, into .whl
#   device run:  run(command="bash experiments/gpu_figures.sh", carry=[".whl"])
# Writes JSON rows under $OUT (or ./out/gpu when OUT is unset). Each step is its own command, so a partial run
# still leaves what finished.
set -uo pipefail
out="${OUT:-out/gpu}"
mkdir -p "$out"
if [ -d .whl ]; then
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl
  export PYTHONPATH=/tmp/site:$PWD
fi
dm() { python3 -m dragmesh2_jax.cli "$@"; }
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv > "$out/gpu.csv" 2>&1
# physics throughput of the full hand task (target: >= 1e6 physics steps/s at 4-8k worlds)
dm bench env --backend mjx --num-envs 1024,4096,8192 --steps 50 --json > "$out/bench_env_mjx.json"
# PICA training at 1024 and 4096 envs, one run and a seed-vmapped column of 3; the paper's per-object budget
# (150 x 64 x 32) at 64 envs; a second object (on MJX other meshes are other static fields, so this measures
# whether it recompiles; the C engine shares the program between these two doors)
dm bench train --backend mjx --num-envs 64,1024,4096 --runs 1,3 --json > "$out/bench_train_mjx.json"
dm objects synth --category door_cabinet --count 2 --seed 0 --out /tmp/doors > /dev/null
dm bench train --backend mjx --object /tmp/doors/door_cabinet_0000,/tmp/doors/door_cabinet_0001 --num-envs 64 \
  --json > "$out/bench_train_two_objects.json"
# wall time of the paper's budget end to end, compile included
/usr/bin/time -v python3 -m dragmesh2_jax.cli train --method pica --out /tmp/budget --epochs 150 --num-envs 64 \
  --backend mjx --quiet > "$out/budget_train.txt" 2>&1
