#!/usr/bin/env bash
# One-seed lever screens on the suite (rules: results/screen/RULE.md): today's recipe against the recipe with one
# lever (hand_seated: the hand's contacts and the seated grasp; pace: the palm's speed bounded as a second CMDP
# constraint beside the recipe's load bound, its rate of steps past it; pace_peak: each episode's peak), on three suite doors today's expert lets go at x4 and x8; resumable (a
# finished run or evaluation is kept).  Usage: bash experiments/hold_screen.sh [RUNS] [LEVER ...]
set -euo pipefail
RUNS=${1:-runs/screen}
shift || true
LEVERS=("${@:-hand_seated}")
mkdir -p runs/suite
for spec in door_cabinet:107 door_cabinet:109 microwave:104; do
  dragmesh2 objects synth --category "${spec%%:*}" --count 1 --seed "${spec##*:}" --out runs/suite > /dev/null
done
for obj in door_cabinet_0107 door_cabinet_0109 microwave_0104; do
  for lever in today "${LEVERS[@]}"; do
    run="$RUNS/${lever}_$obj"
    extra=()
    [ "$lever" = hand_seated ] && extra=(--scene.object-contact hand --task.expert-grasp seated)
    [ "$lever" = pace ] && extra=(--task.reward.constraints \
      relative_load:1.1:horizon:0.05:2:100,palm_speed:0.25:rate:0.05:1:20)
    [ "$lever" = pace_peak ] && extra=(--task.reward.constraints \
      relative_load:1.1:horizon:0.05:2:100,palm_speed:0.25:peak:0.05:1:20)
    [ -d "$run/seed_0/checkpoints/final" ] || \
      dragmesh2 train --object "runs/suite/$obj" --out "$run" --seeds 0 --backend mujoco --quiet "${extra[@]}"
    [ -s "$run.eval.json" ] || \
      dragmesh2 evaluate --checkpoint "$run/seed_0" --damping 1,2,4,8 --mode det --episodes 50 --backend mujoco \
        --json --quiet > "$run.eval.json"
  done
done
