#!/usr/bin/env bash
# As it ran on 2026-12-07, WORK being the folder that held the checkout (main/), the worktrees and
# the outputs (out/); set WORK to run it elsewhere.
WORK=${WORK:?set WORK to the folder holding main/, the worktrees and out/}
while pgrep -f oracle/queue.sh >/dev/null; do sleep 20; done
cd $WORK/runs-oracle
export PYTHONPATH=$WORK/runs-oracle XLA_FLAGS="--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
REL=docs/assets/2026-12-07/latent-control/results/vae
for goal in walk:-1 reach:0.37 walk:1; do
  name=oracle_mpc_h10-${goal/:/}
  $WORK/main/.venv/bin/python -m litl.latent.control $WORK/out/dyn/vae --goal "$goal" --planner oracle_mpc \
    --out "$PWD/$REL/$name.json" 2>&1 | grep -v absl | sed "s|$PWD/docs/assets/2026-12-07/latent-control/||" > "$REL/$name.txt"
  echo "$name rc=${PIPESTATUS[0]} $(date -u +%H:%M:%S)"
  cp $REL/$name.json $REL/$name.txt $WORK/main/$REL/
  (cd $WORK/main && for i in 1 2 3 4 5 6; do git add -- $REL/$name.json $REL/$name.txt && git commit -q -m "latent control: oracle_mpc $goal cell at latent_mpc's settings (VAE run bodies, seeds 0-9, horizon 10, 30 iterations, from 094fddb)" -- $REL/$name.json $REL/$name.txt && break; sleep 7; done)
done
echo done
