#!/usr/bin/env bash
# The second round's trained references, each run's records committed as it ends.
cd /work/runs-retrain
export PYTHONPATH=/work/runs-retrain XLA_FLAGS="--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
PY=/work/main/.venv/bin/python
DEST=docs/assets/2026-12-07/latent-control/retrained
one() {  # name, overrides...
  name=$1; shift
  $PY -m litl "$@" seeds=10 output.animation=false output.progress=false hydra.run.dir=/work/out/retrain/$name > /work/out/retrain/$name.log 2>&1
  echo "$name rc=$? $(date -u +%H:%M:%S)"
  bash /work/out/commit_records.sh /work/out/retrain/$name $DEST/$name "latent control, second round: the $name run's records (seeds 0-9, from 630e262)"
}
mkdir -p /work/out/retrain
one vae-walk-1 observer=vae loop.dynamics.enabled=true task=locomotion task.direction=-1
one sin-walk-1 controller=sinusoid task=locomotion task.direction=-1
one vae-reach0.37 observer=vae loop.dynamics.enabled=true task=position task.target=0.37
one sin-reach0.37 controller=sinusoid task=position task.target=0.37
one sin-walk1 controller=sinusoid
one pca-walk-1 observer=pca loop.dynamics.enabled=true task=locomotion task.direction=-1
one pca-reach0.37 observer=pca loop.dynamics.enabled=true task=position task.target=0.37
echo done
