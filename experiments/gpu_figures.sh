#!/usr/bin/env bash
# The GPU figures of issues 10 and 22 for both MJX implementations, ready to run on a lent device (RESULTS.md §4):
#   here:   ../shared/tools/gpu_wheels.sh warp-lang==1.18.0     # the wheels the GPU image lacks, into .whl
#           experiments/wheel_parts.sh split .whl              # warp-lang (~149 MB) into parts under 64 MiB
#   device: carry the parts over back-to-back calls (ignored files stay on a warm machine between calls), e.g.
#           run(command="true", carry=[".whl/parts/<warp wheel>.part00", ...]) then
#           run(command="bash experiments/gpu_figures.sh", carry=[".whl/<the other wheels>", ...])
# It joins the parts (checking their hash), installs the wheels, and writes JSON rows under $OUT (or ./out/gpu).
# Each step is its own command, so a partial run still leaves what finished.
set -uo pipefail
out="${OUT:-out/gpu}"
mkdir -p "$out"
if [ -d .whl ]; then
  bash experiments/wheel_parts.sh join .whl || exit 2
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl
  export PYTHONPATH=/tmp/site:$PWD
fi
dm() { python3 -m dragmesh2_jax.cli "$@"; }
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv > "$out/gpu.csv" 2>&1
# physics throughput of the full hand task, both implementations (target: >= 1e6 physics steps/s at 4-8k worlds),
# with each engine's contact slots and constraint rows per world
dm bench env --backend mjx --impl jax,warp --num-envs 1024,4096,8192 --steps 50 --json > "$out/bench_env_mjx.json"
# PICA training at 1024 and 4096 envs; a seed-vmapped column of 3 runs; the paper's per-object budget
# (150 x 64 x 32) at 64 envs
for impl in jax warp; do
  dm bench train --backend mjx --impl "$impl" --num-envs 64,1024,4096 --runs 1,3 --json \
    > "$out/bench_train_mjx_$impl.json"
done
# a second object of the same structure (on MJX other meshes are other static fields: does it recompile?)
dm objects synth --category door_cabinet --count 2 --seed 0 --out /tmp/doors > /dev/null
dm bench train --backend mjx --object /tmp/doors/door_cabinet_0000,/tmp/doors/door_cabinet_0001 --num-envs 64 \
  --json > "$out/bench_train_two_objects.json"
# wall time of the paper's budget end to end, compile included (target: < 60 s)
for impl in jax warp; do
  /usr/bin/time -v python3 -m dragmesh2_jax.cli train --method pica --out "/tmp/budget_$impl" --epochs 150 \
    --num-envs 64 --backend mjx --impl "$impl" --quiet > "$out/budget_train_$impl.txt" 2>&1
done
