#!/usr/bin/env bash
# The seventh round's cells (plan.md) on one run, seeds 0-9, into <robot>/results/<obs>/:
#   bash docs/assets/2026-12-07/latent-control/seventh.sh ROBOT_DIR OBS RUN_DIR "VARIANTS" "GOALS"
# ROBOT_DIR arm or shifted; VARIANTS from both explored better (latent_mpc with --data both,
# --data explored, or the buffer's data and --set warm_start=better); GOALS e.g. "reach:0.46 reach:0.54".
set -u
HERE=$(cd "$(dirname "$0")" && pwd)
ROBOT=$1; OBS=$2; RUN=$3; VARIANTS=$4; GOALS=$5
mkdir -p "$HERE/$ROBOT/results/$OBS"
for variant in $VARIANTS; do
  case $variant in
    both|explored) args=(--data "$variant"); name=latent_mpc-$variant;;
    better) args=(--set warm_start=better); name=latent_mpc-buffer-better;;
    *) echo "unknown variant $variant" >&2; exit 2;;
  esac
  for goal in $GOALS; do
    out=$HERE/$ROBOT/results/$OBS/$name-${goal/:/}
    ${PYTHON:-python} -m litl.latent.control "$RUN" --goal "$goal" --planner latent_mpc "${args[@]}" \
      --out "$out.json" 2>&1 | grep -v absl | sed "s|$HERE/||" > "$out.txt"
    echo "$ROBOT $OBS $name-${goal/:/} rc=${PIPESTATUS[0]} $(date -u +%H:%M:%S)"
  done
done
