#!/usr/bin/env bash
# As it ran on 2026-12-07, WORK being the folder that held the checkout (main/), the worktrees and
# the outputs (out/); set WORK to run it elsewhere.
WORK=${WORK:?set WORK to the folder holding main/, the worktrees and out/}
# The second round's trained references, each run's records committed as it ends.
cd $WORK/runs-retrain
export PYTHONPATH=$WORK/runs-retrain XLA_FLAGS="--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
PY=$WORK/main/.venv/bin/python
DEST=docs/assets/2026-12-07/latent-control/retrained
one() {  # name, overrides...
  name=$1; shift
  $PY -m litl "$@" seeds=10 output.animation=false output.progress=false hydra.run.dir=$WORK/out/retrain/$name > $WORK/out/retrain/$name.log 2>&1
  echo "$name rc=$? $(date -u +%H:%M:%S)"
  bash $WORK/out/commit_records.sh $WORK/out/retrain/$name $DEST/$name "latent control, second round: the $name run's records (seeds 0-9, from 630e262)"
}
mkdir -p $WORK/out/retrain
one vae-walk-1 observer=vae loop.dynamics.enabled=true task=locomotion task.direction=-1
one sin-walk-1 controller=sinusoid task=locomotion task.direction=-1
one vae-reach0.37 observer=vae loop.dynamics.enabled=true task=position task.target=0.37
one sin-reach0.37 controller=sinusoid task=position task.target=0.37
one sin-walk1 controller=sinusoid
one pca-walk-1 observer=pca loop.dynamics.enabled=true task=locomotion task.direction=-1
one pca-reach0.37 observer=pca loop.dynamics.enabled=true task=position task.target=0.37
echo done
