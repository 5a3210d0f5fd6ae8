#!/usr/bin/env bash
# A method's adoption runs (issue "Hold on and follow"; results/screen/RULE.md, fifteenth step): per seed, then per
# object, the method trained at its defaults (150 epochs, C engine), its policy evaluated x1-x16 and its expert (the
# run's own drag, grasp and contacts) x1 and x8, det, 50 perturbed starts per cell. Seed by seed, so that a stopped
# sweep leaves whole seeds; resumable: a stopped run resumes, a finished one is only evaluated (evaluations already
# written are computed again).
#   [SEEDS="0 1 2"] [EXPERT=prior] bash experiments/adoption.sh OUT METHOD [OBJECTS] [SHARED]   (about 7 minutes per run
#   on 2 CPU cores)
# EXPERT: the expert in use, "tracking" (the run's drag replayed as PD targets; the default) or "prior" (the residual
# method's prior alone, its residual at zero: the drag at the prior's own steps).
# OBJECTS: names, space-separated; "door" the tuning door, CATEGORY:SEED a suite object (synthesised into runs/suite as
# hold_screen.sh does); default the five adoption objects "45261 45661 door 45780 11712".
# The table: python experiments/adoption_table.py OUT/*_METHOD_s*
set -euo pipefail
out=${1:?OUT}
method=${2:?METHOD}
objects=${3:-45261 45661 door 45780 11712}
shared=${4:-../shared/gapartnet}
folder() {  # an object's folder from its name
  case "$1" in
    door) python -c "from dragmesh2_jax.assets.procedural import packaged_object; print(packaged_object('door_cabinet_0000'))" ;;
    *:*) local obj
         obj=runs/suite/$(printf "%s_%04d" "${1%%:*}" "${1##*:}")
         [ -d "$obj" ] || dragmesh2 objects synth --category "${1%%:*}" --count 1 --seed "${1##*:}" --out runs/suite > /dev/null
         echo "$obj" ;;
    *) echo "$shared/$1" ;;
  esac
}
for s in ${SEEDS:-0 1 2}; do
  for name in $objects; do
    obj=$(folder "$name")
    run="$out/$(basename "$obj")_${method}_s$s"
    if [ ! -f "$run/run.json" ]; then
      dragmesh2 train --method "$method" --object "$obj" --seed "$s" --backend mujoco --out "$run" --quiet
    elif [ ! -e "$run/checkpoints/epoch_0150" ]; then  # the method's 150 epochs
      dragmesh2 train --out "$run" --resume --quiet
    fi
    dragmesh2 evaluate --checkpoint "$run/checkpoints/final" --episodes 50 --mode det --backend mujoco --quiet > /dev/null
    dragmesh2 evaluate --checkpoint "$run/checkpoints/final" --method "${EXPERT:-tracking}" --damping 1,8 --episodes 50 \
      --mode det --backend mujoco --quiet > /dev/null
  done
done
