#!/usr/bin/env bash
# The fifth round's cells on an arm run (seeds 0-9), into arm/results/<obs>/<planner>-<goal>.json:
#   bash docs/assets/2026-12-07/latent-control/arm/cells.sh OBS RUN_DIR "PLANNERS" ["GOALS"]
# PLANNERS from trained rest latent_lqr latent_mpc oracle_mpc_h10 (oracle_mpc at latent_mpc's
# settings, horizon 10, 30 iterations) and retrained (`--planner trained` on a run trained for the
# goal: RUN_DIR is then that run, OBS its observer or sinusoid). GOALS default: the plan's three.
set -u
HERE=$(cd "$(dirname "$0")" && pwd)
OBS=$1; RUN=$2; PLANNERS=$3; GOALS=${4:-"reach:0.46 reach:0.54 reach:0.6"}
mkdir -p "$HERE/results/$OBS"
for planner in $PLANNERS; do
  for goal in $GOALS; do
    name=$planner-${goal/:/}
    case $planner in
      oracle_mpc_h10) arg=oracle_mpc;;
      retrained) arg=trained;;
      *) arg=$planner;;
    esac
    [ "$OBS" = sinusoid ] && name=trained-${goal/:/}
    ${PYTHON:-python} -m litl.latent.control "$RUN" --goal "$goal" --planner "$arg" \
      --out "$HERE/results/$OBS/$name.json" 2>&1 | grep -v absl | sed "s|$HERE/||" > "$HERE/results/$OBS/$name.txt"
    echo "$OBS $name rc=${PIPESTATUS[0]} $(date -u +%H:%M:%S)"
  done
done
