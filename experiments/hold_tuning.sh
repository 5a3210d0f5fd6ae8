#!/usr/bin/env bash
# Issue 20: the recipe's levers on its tuning door, and the CMDP and blind levers on the validation doors. On the
# procedural door (where the recipe is chosen) hold against pica_load (damping [1, 4] instead of [1, 8]), hold_cmdp
# (the wrist load as a CMDP constraint), hold_blind (no force or touch sensing), hold_blind_cmdp (both) and the
# paper's pica and state_only; hold_cmdp and hold_blind on the two validation doors (as
# experiments/hold_validation.sh did hold and pica_load); then the recipe (hold_blind) on the procedural microwave
# and the two tuning drawers. The paper's budget, 3 seeds, 50 episodes per cell, x1/x2/x4/x8, C engine.
# Resumable: reproduce skips what is done.
#   bash experiments/hold_tuning.sh [OUT]      (about 3 hours on 2 CPU cores)
set -euo pipefail
out=${1:-runs/hold_tuning}
shared=${DRAGMESH2_SHARED:-$(cd "$(dirname "$0")/../.." && pwd)/shared}
door=$(python -c "from dragmesh2_jax.assets.procedural import packaged_object; print(packaged_object('door_cabinet_0000'))")
[ -d "$out/objs/microwave_0000" ] || dragmesh2 objects synth --category microwave --count 1 --seed 0 --out "$out/objs"
common=(--seeds 0,1,2 --epochs 150 --episodes 50 --damping 1,2,4,8 --backend mujoco)
dragmesh2 reproduce main --methods hold,pica_load,hold_cmdp,hold_blind,hold_blind_cmdp,pica,state_only --objects "$door" \
  "${common[@]}" --out "$out/door"
dragmesh2 reproduce main --methods hold_cmdp,hold_blind --objects "$shared/gapartnet/45780" \
  "$shared/gapartnet/11712" "${common[@]}" --out "$out/validation"
dragmesh2 reproduce main --methods hold_blind --objects "$out/objs/microwave_0000" "$shared/gapartnet/45261" \
  "$shared/gapartnet/45661" "${common[@]}" --out "$out/recipe"
