#!/usr/bin/env bash
# As it ran on 2026-12-07, WORK being the folder that held the checkout (main/), the worktrees and
# the outputs (out/); set WORK to run it elsewhere.
WORK=${WORK:?set WORK to the folder holding main/, the worktrees and out/}
# As each retrained run ends: its trained cell into results/<obs>/retrained-<goal>.json (sinusoid: results/sinusoid/trained-<goal>.json), committed.
cd $WORK/runs-retrain
export PYTHONPATH=$WORK/runs-retrain XLA_FLAGS="--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
R=docs/assets/2026-12-07/latent-control/results
declare -A GOAL=([walk-1]=walk:-1 [reach0.37]=reach:0.37 [walk1]=walk:1)
for name in vae-walk-1 sin-walk-1 vae-reach0.37 sin-reach0.37 sin-walk1 pca-walk-1 pca-reach0.37; do
  while ! grep -q "^$name rc=" $WORK/out/retrain_queue.log; do sleep 30; done
  obs=${name%%-*}; goal=${name#*-}
  if [ $obs = sin ]; then out=$R/sinusoid/trained-$goal; else out=$R/$obs/retrained-$goal; fi
  mkdir -p $(dirname $out) $WORK/main/$(dirname $out)
  $WORK/main/.venv/bin/python -m litl.latent.control $WORK/out/retrain/$name --goal ${GOAL[$goal]} --planner trained --out $PWD/$out.json 2>&1 | grep -v absl | sed "s|$PWD/docs/assets/2026-12-07/latent-control/||" > $out.txt
  echo "$name cell rc=${PIPESTATUS[0]} $(date -u +%H:%M:%S)"
  cp $out.json $out.txt $WORK/main/$(dirname $out)/
  (cd $WORK/main && for i in 1 2 3 4 5 6; do git add -- $out.json $out.txt && git commit -q -m "latent control, second round: the trained cell of the $name run" -- $out.json $out.txt && break; sleep 7; done)
done
echo done
