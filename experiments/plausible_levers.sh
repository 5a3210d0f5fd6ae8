#!/usr/bin/env bash
# Issue 33 item 2, two more levers on the tuning door (procedural door_cabinet_0000), each against plausible_load
# (the wrist load alone, 300 fine-tune epochs from the recipe's epoch-150 checkpoints: experiments/plausible_hold.sh):
#   sensed  the load seen by the policy: `hold` (the recipe with the contact-load sensors) for 150 epochs, then
#           plausible_load for 300;
#   pace    a pace target: the recipe's epoch-150 checkpoints (RECIPE_RUNS, from plausible_hold.sh) under
#           plausible_pace (the load and the part's lag behind the expert drag's schedule) for 300.
# 3 seeds, 50 perturbed starts per cell at x1-x16, det, C engine. Resumable: a stopped run resumes.
#   bash experiments/plausible_levers.sh [OUT] [RECIPE_RUNS]    (about 1 hour on 2 CPU cores)
# The table: python experiments/plausible_table.py OUT --object <door> --row "LABEL=GLOB" ... (RESULTS.md §3b).
set -euo pipefail
out=${1:-runs/plausible_levers}
recipe_runs=${2:-runs/plausible_hold/door/runs/door_cabinet_0000}
door=$(python -c "from dragmesh2_jax.assets.procedural import packaged_object; print(packaged_object('door_cabinet_0000'))")
cells=(--damping 1,2,4,8,16 --episodes 50 --mode det --backend mujoco)

finetune() {  # PARENT_CHECKPOINT RECIPE RUN EPOCHS: the fine-tune, resumed if stopped, then its cells
  if [ ! -f "$3/run.json" ]; then
    dragmesh2 finetune --checkpoint "$1" --recipe "$2" --epochs "$4" --out "$3" --backend mujoco --quiet
  else
    dragmesh2 train --out "$3" --resume --quiet
  fi
  dragmesh2 evaluate --checkpoint "$3/checkpoints/epoch_$(printf %04d $((150 + $4)))" "${cells[@]}"
}

for s in 0 1 2; do
  run="$out/hold_s$s"
  if [ ! -f "$run/run.json" ]; then
    dragmesh2 train --method hold --object "$door" --seed "$s" --epochs 150 --backend mujoco --out "$run" --quiet
  else
    dragmesh2 train --out "$run" --resume --quiet
  fi
  dragmesh2 evaluate --checkpoint "$run/checkpoints/epoch_0150" "${cells[@]}"
  finetune "$run/checkpoints/epoch_0150" plausible_load "$out/hold_load_s$s" 300
done
for s in 0 1 2; do
  finetune "$recipe_runs/hold_blind_s$s/checkpoints/epoch_0150" plausible_pace "$out/plausible_pace_s$s" 300
done
