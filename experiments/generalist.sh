#!/usr/bin/env bash
# Issue 21: the generalist table. Per seed, one `hold` policy over 32 procedural objects in the paper's Table 1 mix
# (2 held aside for best_robust) for 600 epochs, as many env steps as the four 150-epoch specialists together; zero-shot
# (best_robust and final) and fine-tuned for 20 epochs on each shared object, beside each object's specialist; 3 seeds,
# 50 episodes per cell, x1-x8, C engine. Resumable: reproduce skips what is done.
#   bash experiments/generalist.sh [OUT]      (about 2.5 hours on 2 CPU cores)
# The run of RESULTS §6 put the issue-20 validation runs of 45780 and 11712 (experiments/hold_validation.sh: the same
# specialists, seeds and evaluation protocol) under OUT/runs/ first, so that reproduce reused them.
set -euo pipefail
out=${1:-runs/generalist}
shared=${DRAGMESH2_SHARED:-$(cd "$(dirname "$0")/../.." && pwd)/shared}
dragmesh2 reproduce generalist --objects "$shared"/gapartnet/{45261,45661,45780,11712} --seeds 0,1,2 --epochs 150 \
  --episodes 50 --damping 1,2,4,8 --video-every 0 --out "$out" --backend mujoco
