#!/usr/bin/env bash
# Issue 33 item 2: the recipe held within a person's reach. On the tuning door (procedural door_cabinet_0000, where
# the recipe was chosen): the recipe (hold_blind) at its budget (300 epochs, final checkpoint) against the same runs'
# epoch-150 checkpoints fine-tuned for 150 epochs under the `plausible` constraints (the palm's pace, the wrist load
# and saturation; 300 epochs in all), their multipliers capped at 20 and at 100; 3 seeds, 50 perturbed starts per
# cell, x1-x8 and x16, det and stoch, C engine; the physical figures are in every cell. The paper's methods (pica,
# state_only) beside them at the same budget and checkpoint (300 epochs, final). Resumable: reproduce skips what is
# done, a stopped fine-tune resumes. RECIPES (default "plausible plausible_cap100") names the fine-tunes.
#   bash experiments/plausible_hold.sh [OUT]      (about 3 hours on 2 CPU cores)
#   RECIPES=plausible_load bash experiments/plausible_hold.sh [OUT]
set -euo pipefail
out=${1:-runs/plausible_hold}
door=$(python -c "from dragmesh2_jax.assets.procedural import packaged_object; print(packaged_object('door_cabinet_0000'))")
cells=(--damping 1,2,4,8,16 --episodes 50 --mode det,stoch --backend mujoco)
dragmesh2 reproduce main --methods hold_blind --objects "$door" --seeds 0,1,2 --epochs 300 "${cells[@]}" \
  --out "$out/door"
dragmesh2 reproduce main --methods pica,state_only --objects "$door" --seeds 0,1,2 --epochs 300 --checkpoint-rule final \
  "${cells[@]}" --out "$out/door_paper"
for recipe in ${RECIPES:-plausible plausible_cap100}; do for s in 0 1 2; do
  ft="$out/$recipe/s$s"
  if [ ! -f "$ft/run.json" ]; then
    dragmesh2 finetune --checkpoint "$out/door/runs/door_cabinet_0000/hold_blind_s$s/checkpoints/epoch_0150" \
      --recipe "$recipe" --out "$ft" --backend mujoco --quiet
  else
    dragmesh2 train --out "$ft" --resume --quiet  # finishes a stopped fine-tune (nothing to do once it has)
  fi
  dragmesh2 evaluate --checkpoint "$ft" "${cells[@]}"  # kept in $ft/evaluations/
done; done
