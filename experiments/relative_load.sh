#!/usr/bin/env bash
# Issue 33 item 2, the load bound relative to each object's expert: hold_blind_residual_relative on the validation
# doors, the tuning drawers and the tuning door (procedural door_cabinet_0000, where its limit, the expert's 99-101 N
# at x1-x8, is hold_blind_residual_smooth's 100 N), 3 seeds each, every cell 50 perturbed starts at x1-x16, det, C
# engine. Resumable: a stopped run resumes, a finished one is only evaluated.
#   [SEEDS="0 1 2"] bash experiments/relative_load.sh [OUT] [SHARED] [METHOD] [OBJECTS]   (about 12 minutes per object on 2 CPU cores)
# METHOD defaults to hold_blind_residual_relative; OBJECTS (names, space-separated; "door" the tuning door) to all
# five, e.g. hold_blind_residual_relative_own "45661 door 45261 11712 45780" (RESULTS.md §3b).
# The tables: python experiments/plausible_table.py OUT --object <object> --row "LABEL=GLOB" ... (RESULTS.md §3b).
set -euo pipefail
out=${1:-runs/relative_load}
shared=${2:-../shared/gapartnet}
door=$(python -c "from dragmesh2_jax.assets.procedural import packaged_object; print(packaged_object('door_cabinet_0000'))")
method=${3:-hold_blind_residual_relative}
for name in ${4:-45780 11712 45661 45261 door}; do
  obj=$([ "$name" = door ] && echo "$door" || echo "$shared/$name")
  for s in ${SEEDS:-0 1 2}; do
    run="$out/$(basename "$obj")_${method}_s$s"
    if [ ! -f "$run/run.json" ]; then
      dragmesh2 train --method "$method" --object "$obj" --seed "$s" --backend mujoco --out "$run" --quiet
    elif [ ! -e "$run/checkpoints/epoch_0150" ]; then  # the method's 150 epochs
      dragmesh2 train --out "$run" --resume --quiet
    fi
    dragmesh2 evaluate --checkpoint "$run" --episodes 50 --mode det --backend mujoco
  done
done
