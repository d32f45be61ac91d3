#!/usr/bin/env bash
# As it ran on 2026-12-07, WORK being the folder that held the checkout (main/), the worktrees and
# the outputs (out/); set WORK to run it elsewhere.
WORK=${WORK:?set WORK to the folder holding main/, the worktrees and out/}
cd $WORK/runs-long
export PYTHONPATH=$WORK/runs-long XLA_FLAGS="--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
R=docs/assets/2026-12-07/latent-control/results
for planner in latent_lqr rest latent_mpc; do
  for obs in vae pca; do
    out=$R/$obs/$planner-reach0.37-2s; mkdir -p $R/$obs
    $WORK/main/.venv/bin/python -m litl.latent.control $WORK/out/dyn/$obs --goal reach:0.37 --planner $planner --control-steps 64 --out $PWD/$out.json 2>&1 | grep -v absl | sed "s|$PWD/docs/assets/2026-12-07/latent-control/||" > $out.txt
    echo "$obs $planner rc=${PIPESTATUS[0]} $(date -u +%H:%M:%S)"
    cp $out.json $out.txt $WORK/main/$R/$obs/
    (cd $WORK/main && for i in 1 2 3 4 5 6; do git add -- $out.json $out.txt && git commit -q -m "latent control, fourth round: $planner reach:0.37 over 2 s ($obs run, seeds 0-9, from 8c59f7c)" -- $out.json $out.txt && break; sleep 7; done)
  done
done
echo done
