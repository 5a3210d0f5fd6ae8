#!/usr/bin/env bash
# Issue 20: the recipe (hold_blind) at its final checkpoint against the paper's best_robust selection, at the paper's
# budget and at twice it, on its tuning door, the validation doors and the tuning objects. The paper's budget runs
# are experiments/hold_tuning.sh's (OUT); the 300-epoch runs continue them (the learning rate is constant, so
# resuming to 300 epochs is a 300-epoch run). 3 seeds, 50 episodes per cell, x1/x2/x4/x8, C engine.
#   bash experiments/hold_budget.sh [OUT]      (about 1 hour on 2 CPU cores after hold_tuning.sh)
set -euo pipefail
out=${1:-runs/hold_tuning}
shared=${DRAGMESH2_SHARED:-$(cd "$(dirname "$0")/../.." && pwd)/shared}
door=$(python -c "from dragmesh2_jax.assets.procedural import packaged_object; print(packaged_object('door_cabinet_0000'))")
cells=(--damping 1,2,4,8 --mode det,stoch --episodes 50 --backend mujoco)
for run in "$out"/{door,validation,recipe}/runs/*/hold_blind_s*; do  # the paper's budget: the final checkpoints
  dragmesh2 evaluate --checkpoint "$run/checkpoints/final" "${cells[@]}" --json > /dev/null
done
for part in door validation; do  # twice the budget: copies of the runs, extended
  mkdir -p "$out/x2/$part/runs"
  for run in "$out/$part"/runs/*/hold_blind_s*; do
    dest="$out/x2/$part/runs/$(basename "$(dirname "$run")")"
    [ -d "$dest/$(basename "$run")" ] || { mkdir -p "$dest"; cp -r "$run" "$dest/"; rm -rf "$dest/$(basename "$run")/evaluations"; }
  done
done
common=(--methods hold_blind --seeds 0,1,2 --epochs 300 --episodes 50 --damping 1,2,4,8 --backend mujoco)
dragmesh2 reproduce main --objects "$door" "${common[@]}" --out "$out/x2/door"
dragmesh2 reproduce main --objects "$shared/gapartnet/45780" "$shared/gapartnet/11712" "${common[@]}" --out "$out/x2/validation"
for run in "$out"/x2/*/runs/*/hold_blind_s*; do
  dragmesh2 evaluate --checkpoint "$run/checkpoints/final" "${cells[@]}" --json > /dev/null
done
