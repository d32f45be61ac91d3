#!/usr/bin/env bash
# As it ran on 2026-12-07, WORK being the folder that held the checkout (main/), the worktrees and
# the outputs (out/); set WORK to run it elsewhere.
WORK=${WORK:?set WORK to the folder holding main/, the worktrees and out/}
while pgrep -f oracle/queue2.sh >/dev/null; do sleep 20; done
cd $WORK/main && git worktree add -f $WORK/runs-ilqr e8a2f14 -q 2>/dev/null
cd $WORK/runs-ilqr
export PYTHONPATH=$WORK/runs-ilqr XLA_FLAGS="--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
R=docs/assets/2026-12-07/latent-control/results
for goal in walk:-1 reach:0.37 walk:1; do
  for obs in vae pca; do
    name=latent_ilqr-${goal/:/}; out=$R/$obs/$name; mkdir -p $R/$obs
    $WORK/main/.venv/bin/python -m litl.latent.control $WORK/out/dyn/$obs --goal $goal --planner latent_ilqr --out $PWD/$out.json 2>&1 | grep -v absl | sed "s|$PWD/docs/assets/2026-12-07/latent-control/||" > $out.txt
    echo "$obs $name rc=${PIPESTATUS[0]} $(date -u +%H:%M:%S)"
    cp $out.json $out.txt $WORK/main/$R/$obs/
    (cd $WORK/main && for i in 1 2 3 4 5 6; do git add -- $out.json $out.txt && git commit -q -m "latent control, third round: latent_ilqr $goal cell ($obs run, seeds 0-9, from e8a2f14)" -- $out.json $out.txt && break; sleep 7; done)
  done
done
echo done
