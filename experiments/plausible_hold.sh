#!/usr/bin/env bash
# Issue 33 item 2: the recipe held within a person's reach. On the tuning door (procedural door_cabinet_0000, where
# the recipe was chosen) hold_plausible (hold_blind with the palm's pace, the wrist load and saturation as CMDP
# constraints) against hold_blind, both at the recipe's budget (300 epochs) and checkpoint rule (final), 3 seeds, 50
# perturbed starts per cell, x1-x8 and x16, C engine; the physical figures are in every cell.
# Resumable: reproduce skips what is done.
#   bash experiments/plausible_hold.sh [OUT]      (about 1 hour on 2 CPU cores)
set -euo pipefail
out=${1:-runs/plausible_hold}
door=$(python -c "from dragmesh2_jax.assets.procedural import packaged_object; print(packaged_object('door_cabinet_0000'))")
dragmesh2 reproduce main --methods hold_plausible,hold_blind --objects "$door" --seeds 0,1,2 --epochs 300 --episodes 50 \
  --damping 1,2,4,8,16 --backend mujoco --out "$out/door"
