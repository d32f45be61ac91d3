#!/usr/bin/env bash
# As it ran on 2026-12-07; WORK: the folder that held the checkout (main/), the worktrees and out/.
WORK=${WORK:?set WORK}
# sep-CMA-ES over design=all on the demo bunny at 20x litl's budget, one seed per process, from c019d17: bash cmaes_bunny.sh "SEEDS" [A_LOG_TO_WAIT_FOR_ITS_rc=_LINE]
export XLA_FLAGS="--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
PY=$WORK/main/.venv/bin/python
[ -n "${2:-}" ] && while ! grep -q "^rc=" "$2" 2>/dev/null; do sleep 20; done
cd $WORK/runs-c019
mkdir -p $WORK/out/cmaes-bunny
for s in $1; do
  if [ "$(date -u +%H%M)" -gt 1335 ]; then echo "stop before seed $s $(date -u)" >> $WORK/out/cmaes-bunny/queue.log; break; fi
  rm -rf $WORK/out/cmaes-bunny/seed$s
  $PY -m litl robot=bunny optimizer=sep_cmaes design=all optimizer.sep_cmaes.population=16 optimizer.sep_cmaes.sigma=0.1 optimizer.sep_cmaes.generations=459 seeds=1 seed=$s output.animation=false output.progress=false hydra.run.dir=$WORK/out/cmaes-bunny/seed$s > $WORK/out/cmaes-bunny/seed$s.log 2>&1
  rc=$?
  echo "cmaes bunny seed $s rc=$rc $(date -u)" >> $WORK/out/cmaes-bunny/queue.log
  [ $rc -eq 0 ] && $WORK/out/commit_records.sh $WORK/out/cmaes-bunny/seed$s docs/assets/2026-12-07/design-observers/records/bunny/sep-cmaes-all/seed$s "design observers: sep-CMA-ES design=all 20x on the bunny, seed $s (c019d17): records"
done
