#!/usr/bin/env bash
# The plan's cells: every planner and goal on the reported runs (seeds 0-9), into results/<observer>/.
#   bash docs/assets/2026-12-07/latent-control/cells.sh VAE_RUN PCA_RUN "PLANNERS" [--set ... for latent_mpc]
# e.g. PYTHON=.venv/bin/python cells.sh VAE_RUN PCA_RUN "trained rest latent_lqr"; SEEDS=0,1,2 limits the seeds
set -u
HERE=$(cd "$(dirname "$0")" && pwd)
VAE=$1; PCA=$2; PLANNERS=$3; shift 3
for planner in $PLANNERS; do
  for pair in "vae $VAE" "pca $PCA"; do
    set -- $pair "$@"; obs=$1; run=$2; shift 2
    [ "$planner" = "oracle_mpc" ] && [ "$obs" = "pca" ] && continue  # the oracle reads no observer: the VAE run's bodies
    for goal in walk:1 walk:-1 reach:0.37; do
      [ "$planner" = "latent_lqr" ] && [ "${goal%%:*}" = "walk" ] && continue
      name=$planner-${goal/:/}
      extra=()
      case $planner in latent_mpc*|oracle_mpc) extra=("$@");; esac
      [ "$planner" = "latent_mpc_linear" ] && { planner_arg=latent_mpc; extra+=(--set model=linear); } || planner_arg=$planner
      mkdir -p "$HERE/results/$obs"
      seeds=(); [ -n "${SEEDS:-}" ] && seeds=(--seeds "$SEEDS")
      ${PYTHON:-python} -m litl.latent.control "$run" --goal "$goal" --planner "$planner_arg" "${extra[@]}" "${seeds[@]}" \
        --out "$HERE/results/$obs/$name.json" 2>&1 | grep -v absl | sed "s|$HERE/||" > "$HERE/results/$obs/$name.txt"
      echo "$obs $name rc=${PIPESTATUS[0]} $(date -u +%H:%M:%S)"
    done
  done
done
