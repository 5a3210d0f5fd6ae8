#!/usr/bin/env bash
# Issue 36's lever: the generalist with the object curriculum (`--task.object-curriculum BETA`, default 0.5: half the
# resets drawn towards the objects it fails) for EPOCHS (default 1000: 2.05 M env steps), once per seed of SEEDS
# (default "0 1 2"), into OUT/gcur_s<seed>; a run that stopped goes on with --resume. Compare with the PPO
# generalist's checkpoints at the same epoch (experiments/generalist_levers.py).
set -euo pipefail
out="${1:?usage: generalist_curriculum.sh OUT}"
mkdir -p "$out"
for seed in ${SEEDS:-0 1 2}; do
  run="$out/gcur_s$seed"
  [ -d "$run/checkpoints/final" ] && continue
  if [ -f "$run/run.json" ]; then
    dragmesh2 train --generalist --out "$run" --resume --quiet
  else
    dragmesh2 train --generalist --out "$run" --seed "$seed" --backend mujoco \
      --task.object-curriculum "${BETA:-0.5}" --epochs "${EPOCHS:-1000}" --quiet
  fi
done
