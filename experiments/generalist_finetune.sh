#!/usr/bin/env bash
# Issue 36's fine-tuned row: the packaged generalist (or CHECKPOINT) fine-tuned for EPOCHS (20) epochs on each shared
# object (`finetune --recipe continued --object`), then evaluated at x1/x2/x4/x8, det and stoch, EPISODES (50)
# perturbed starts per cell. Resumable: a finished object is skipped. Writes OUT/ft_<id> and OUT/ft_<id>.json.
set -euo pipefail
out="${1:?usage: generalist_finetune.sh OUT}"
ck="${CHECKPOINT:-generalist}"
mkdir -p "$out"
for oid in ${OBJECTS:-45261 45661 45780 11712}; do
  [ -s "$out/ft_$oid.json" ] && continue
  [ -d "$out/ft_$oid/checkpoints/final" ] || { rm -rf "$out/ft_$oid"; dragmesh2 finetune --checkpoint "$ck" \
    --recipe continued --epochs "${EPOCHS:-20}" --robust-every 0 --object "../shared/gapartnet/$oid" \
    --out "$out/ft_$oid" --backend mujoco --quiet; }
  dragmesh2 evaluate --checkpoint "$out/ft_$oid" --damping 1,2,4,8 --episodes "${EPISODES:-50}" --backend mujoco \
    --json > "$out/ft_$oid.json.tmp" && mv "$out/ft_$oid.json.tmp" "$out/ft_$oid.json"
done
