#!/usr/bin/env bash
# Issue 21: the scaling plot. Per seed and training-set size N (1, 8, 32, 128, 277 nested procedural objects in the
# paper's Table 1 mix), one `hold` policy for 200 epochs x 64 x 32 = 409,600 env steps (the --epochs 50 x 4 objects
# generalist budget, the same for every N), its checkpoints at epochs 66, 132 and 200 evaluated zero-shot on the four
# shared objects (never trained on): det, x1 and x4, 30 episodes per cell from perturbed starts; 3 seeds, C engine.
# Resumable: reproduce skips what is done.
#   bash experiments/scaling.sh [OUT]      (2.05 hours on 2 CPU cores, RESULTS §6b)
set -euo pipefail
out=${1:-runs/scaling}
shared=${DRAGMESH2_SHARED:-$(cd "$(dirname "$0")/../.." && pwd)/shared}
dragmesh2 reproduce scaling --objects "$shared"/gapartnet/{45261,45661,45780,11712} --seeds 0,1,2 --epochs 50 \
  --episodes 30 --damping 1,4 --mode det --video-every 0 --out "$out" --backend mujoco
