#!/usr/bin/env bash
# Issue 55 item 2: the distilled generalist against the residual generalist from scratch at the same wall time.
#   [SEEDS="0 1 2"] [PER_CATEGORY=1] [TEACHER_EPOCHS=150] [EPOCHS=1221] bash experiments/distill.sh OUT
# 1. The generalist's objects (train --generalist's, 40 to train on and 10 held aside), built into the first seed's
#    student folder, OUT/student_sS/objects (each seed's student builds the same objects by content: procedural objects
#    are reproducible, and teachers are matched to a student's objects by content).
# 2. Teachers: PER_CATEGORY training objects of each category (the first ones; the coverage is the stated subset),
#    each a generalist_residual specialist of TEACHER_EPOCHS on its object (C engine), in OUT/teachers/NAME; one set
#    for every seed (the teachers' wall time is counted once in the table: each run's log.csv "seconds").
# 3. Per seed, the student: train --generalist --method generalist_distilled --teachers OUT/teachers/* for EPOCHS
#    (2.5 M env steps at the default batch, the residual generalist's budget in RESULTS §4).
# Not here: the residual generalist from scratch at the same wall time (train --generalist --method
# generalist_residual, its epochs from the student's seconds plus the teachers', each log.csv's last "seconds").
# Resumable: a finished teacher is kept, a stopped one resumes; a student resumes.
set -euo pipefail
out=${1:?OUT}
epochs=${EPOCHS:-1221}
seeds=${SEEDS:-0 1 2}
mkdir -p "$out"
python - "$out/student_s${seeds%% *}" "${PER_CATEGORY:-1}" > "$out/teachers.txt" <<'EOF'
import sys
from collections import defaultdict

from dragmesh2_jax.assets.procedural import category_of
from dragmesh2_jax.runs.generalist import generalist_objects

objects, _, holdout = generalist_objects(sys.argv[1], progress=False)
first = defaultdict(list)
for o in objects[:len(objects) - holdout]:
    first[category_of(o)].append(o)
for category, folders in sorted(first.items()):
    print("\n".join(folders[:int(sys.argv[2])]))
EOF
while read -r obj; do
  run="$out/teachers/$(basename "$obj")"
  if [ ! -f "$run/run.json" ]; then
    dragmesh2 train --method generalist_residual --object "$obj" --epochs "${TEACHER_EPOCHS:-150}" --save-every 10 \
      --robust-every 0 --backend mujoco --out "$run" --quiet < /dev/null
  elif [ ! -e "$run/checkpoints/final" ]; then
    dragmesh2 train --out "$run" --resume --quiet < /dev/null
  fi
done < "$out/teachers.txt"
for s in $seeds; do
  student="$out/student_s$s"
  if [ -f "$student/run.json" ]; then
    dragmesh2 train --generalist --out "$student" --resume --quiet
  else
    dragmesh2 train --generalist --method generalist_distilled --teachers "$out"/teachers/* --seed "$s" \
      --epochs "$epochs" --backend mujoco --out "$student" --quiet
  fi
done
