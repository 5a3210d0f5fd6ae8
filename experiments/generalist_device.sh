#!/usr/bin/env bash
# Train (or go on with) one generalist seed on a lent device's CPU cores for a while, and bring its run folder back.
# The generalist steps 50 object structures, which MJX cannot batch (RESULTS §6d), so it runs on the C engine, whose
# worker threads take every core the machine has (16 on the lent H200 machine, 2 here).
#   device: one call carrying .whl/base (see experiments/gpu_figures.sh), and runs/generalist_sN.tgz.part* to go on:
#             SEED=N GPU_BUDGET_S=<seconds> bash experiments/generalist_device.sh
#   here:   cat <files_at>/generalist_sN.tgz.part* | tar -xz -C runs
#           dragmesh2 train --generalist --out runs/generalist_sN --seed N --backend mujoco --resume
# A device call returns at most 8 files of 16 MiB: the folder travels back as a gzipped tar cut into parts, with
# only its last KEEP checkpoints (each ~9 MB; the run resumes from the newest). Going on there again needs the parts,
# the wheels (40 MB) and the tree (13 MB) in one call's 64 MiB: a folder of 619 epochs came back as 55 MB, so a seed
# starts there and goes on here (its record's paths are the same on both machines: the device runs in this path).
set -uo pipefail
seed=${SEED:?which seed}; budget=${GPU_BUDGET_S:-480}; keep=${KEEP:-2}
name=generalist_s$seed; out=${OUT:-out/device}
mkdir -p "$out" runs
export PYTHONUNBUFFERED=1 JAX_PLATFORMS=cpu  # the network is small; the C engine's threads do the work
if [ -d .whl/base ]; then
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site \
    $(find .whl/base -type f -name '*.whl') || exit 2
  export PYTHONPATH=/tmp/site:$PWD
fi
if ls runs/$name.tgz.part* > /dev/null 2>&1; then
  cat runs/$name.tgz.part* | tar -xz -C runs || exit 2
fi
resume=(); [ -f runs/$name/run.json ] && resume=(--resume)
{ nproc; lscpu | grep -E '^Model name'; } > "$out/machine.txt"
timeout "$((budget - SECONDS - 40))" python3 -m dragmesh2_jax.cli train --generalist --out "runs/$name" \
  --seed "$seed" --backend mujoco "${resume[@]}" > "$out/train.log" 2>&1
echo "train rc=$? after $SECONDS s" >> "$out/train.log"
old=$(ls -d runs/$name/checkpoints/epoch_* 2>/dev/null | sort | head -n -"$keep")
tar -cz -C runs $(for d in $old; do echo "--exclude=$name/checkpoints/$(basename "$d")"; done) "$name" \
  | split -b 15M -d -a 1 - "$out/$name.tgz.part"
ls -la "$out" >> "$out/train.log"
