#!/usr/bin/env bash
# Issue 20: the recipe (hold) against pica_load on the two validation doors, the paper's budget, 3 seeds, 50
# episodes per cell, x1/x2/x4/x8; then how each seed loses 45780. Resumable: reproduce skips what is done.
#   bash experiments/hold_validation.sh [OUT]      (about 50 minutes on 2 CPU cores)
set -euo pipefail
out=${1:-runs/hold_validation}
shared=${DRAGMESH2_SHARED:-$(cd "$(dirname "$0")/../.." && pwd)/shared}
dragmesh2 reproduce main --methods hold,pica_load --objects "$shared/gapartnet/45780" "$shared/gapartnet/11712" \
  --seeds 0,1,2 --epochs 150 --episodes 50 --damping 1,2,4,8 --out "$out" --backend mujoco
for m in hold pica_load; do
  python "$(dirname "$0")/policy_analysis.py" --runs "$out"/runs/45780/${m}_s{0,1,2} --damping 1,4,8 --episodes 16 \
    --backend mujoco --out "$out/failure_45780_$m.json"
done
