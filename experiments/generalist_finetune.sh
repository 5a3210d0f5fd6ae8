#!/usr/bin/env bash
# Issue 36's fine-tuned row: the packaged generalist (or CHECKPOINT) fine-tuned for EPOCHS (20) epochs on each shared
# object (`finetune --recipe continued --object`), once per seed of SEEDS (default: 0), then evaluated at
# x1/x2/x4/x8, det and stoch, EPISODES (50) perturbed starts per cell. Resumable: a finished fine-tune is skipped.
# Writes OUT/ft_<id>_s<seed> and OUT/ft_<id>_s<seed>.json.
set -euo pipefail
out="${1:?usage: generalist_finetune.sh OUT}"
ck="${CHECKPOINT:-generalist}"
mkdir -p "$out"
for seed in ${SEEDS:-0}; do
  for oid in ${OBJECTS:-45261 45661 45780 11712}; do
    run="$out/ft_${oid}_s$seed"
    [ -s "$run.json" ] && continue
    [ -d "$run/checkpoints/final" ] || { rm -rf "$run"; dragmesh2 finetune --checkpoint "$ck" --recipe continued \
      --epochs "${EPOCHS:-20}" --robust-every 0 --seed "$seed" --object "../shared/gapartnet/$oid" --out "$run" \
      --backend mujoco --quiet; }
    dragmesh2 evaluate --checkpoint "$run" --damping 1,2,4,8 --episodes "${EPISODES:-50}" --backend mujoco \
      --json > "$run.json.tmp" && mv "$run.json.tmp" "$run.json"
  done
done
