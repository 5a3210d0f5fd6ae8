#!/usr/bin/env bash
# One-seed lever screens on the suite (rules: results/screen/RULE.md): today's recipe against the recipe with one
# lever (hand_seated: the hand's contacts and the seated grasp; pace: the palm's speed bounded as a second CMDP
# constraint beside the recipe's load bound, its rate of steps past it; pace_peak: each episode's peak; holds: the
# expert's placement chosen by the load it holds; seated_holds: that with the seated grasp; grip: the hand's contacts
# and finger drives of 2 N m, so the policy can close the grip past the expert's; yield: the prior's drag target at most
# 0.2 of the range ahead of the part; grip_yield: both; seat: grip's physics under the recipe's own trajectory, its seat
# planned on MuJoCo's soft contacts; seat_yield: seat and yield; seat_fine: seat, the whole hand's residual at a
# quarter; seat_target: seat, the residual offsetting the drag's PD target, not its clipped increment;
# seat_target_yield: that and yield), on three suite doors today's expert
# lets go at x4 and x8 (or OBJECTS, suite objects as category:seed); resumable (a finished run or evaluation is kept).
# Usage: [SEEDS="0 1 2"] [WITH_TODAY=0] [OBJECTS="door_cabinet:111 ..."] bash experiments/hold_screen.sh [RUNS] [LEVER ...]
# (seed 0's run is RUNS/LEVER_OBJECT, seed S's RUNS/LEVER_OBJECT_sS)
set -euo pipefail
RUNS=${1:-runs/screen}
shift || true
LEVERS=("${@:-hand_seated}")
SEEDS=${SEEDS:-0}
WITH_TODAY=${WITH_TODAY:-1}  # 0: the levers' runs alone
OBJECTS=${OBJECTS:-door_cabinet:107 door_cabinet:109 microwave:104}
# the hand's contacts with 2 N m fingers, and that under the recipe's own trajectory (planned on MuJoCo's contacts)
grip=(--scene.object-contact hand --scene.hand.finger.force-limit 2)
seat=("${grip[@]}" --task.expert-plan-contact mujoco)
mkdir -p runs/suite
objs=()
for spec in $OBJECTS; do
  obj=$(printf "%s_%04d" "${spec%%:*}" "${spec##*:}")
  [ -d "runs/suite/$obj" ] || \
    dragmesh2 objects synth --category "${spec%%:*}" --count 1 --seed "${spec##*:}" --out runs/suite > /dev/null
  objs+=("$obj")
done
for obj in "${objs[@]}"; do
  settings=("${LEVERS[@]}")
  [ "$WITH_TODAY" = 0 ] || settings=(today "${LEVERS[@]}")
  for lever in "${settings[@]}"; do
   for seed in $SEEDS; do
    run="$RUNS/${lever}_$obj"
    [ "$seed" = 0 ] || run="${run}_s$seed"
    extra=()
    [ "$lever" = hand_seated ] && extra=(--scene.object-contact hand --task.expert-grasp seated)
    [ "$lever" = pace ] && extra=(--task.reward.constraints \
      relative_load:1.1:horizon:0.05:2:100,palm_speed:0.25:rate:0.05:1:20)
    [ "$lever" = holds ] && extra=(--task.expert-placement holds)
    [ "$lever" = seated_holds ] && extra=(--task.expert-grasp seated --task.expert-placement holds)
    [ "$lever" = grip ] && extra=("${grip[@]}")
    [ "$lever" = yield ] && extra=(--task.prior-lead 0.2)
    [ "$lever" = grip_yield ] && extra=("${grip[@]}" --task.prior-lead 0.2)
    [ "$lever" = seat ] && extra=("${seat[@]}")
    [ "$lever" = seat_yield ] && extra=("${seat[@]}" --task.prior-lead 0.2)
    [ "$lever" = seat_fine ] && extra=("${seat[@]}" --task.residual-scope hand)
    [ "$lever" = seat_target ] && extra=("${seat[@]}" --task.residual-on target)
    [ "$lever" = seat_target_yield ] && extra=("${seat[@]}" --task.residual-on target --task.prior-lead 0.2)
    [ "$lever" = pace_peak ] && extra=(--task.reward.constraints \
      relative_load:1.1:horizon:0.05:2:100,palm_speed:0.25:peak:0.05:1:20)
    [ -d "$run/seed_$seed/checkpoints/final" ] || \
      dragmesh2 train --object "runs/suite/$obj" --out "$run" --seeds "$seed" --backend mujoco --quiet "${extra[@]}"
    [ -s "$run.eval.json" ] || \
      dragmesh2 evaluate --checkpoint "$run/seed_$seed" --damping 1,2,4,8 --mode det --episodes 50 --backend mujoco \
        --json --quiet > "$run.eval.json"
   done
  done
done
