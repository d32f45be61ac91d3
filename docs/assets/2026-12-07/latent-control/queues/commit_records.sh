#!/usr/bin/env bash
# As it ran on 2026-12-07, WORK being the folder that held the checkout (main/), the worktrees and
# the outputs (out/); set WORK to run it elsewhere.
WORK=${WORK:?set WORK to the folder holding main/, the worktrees and out/}
# copy one ended run's records into main and commit only that path: commit_records.sh SRC DEST MSG
SRC=$1; DEST=$WORK/main/$2; MSG=$3
mkdir -p "$DEST"
for f in run.json final.json learning.jsonl; do [ -f "$SRC/$f" ] && cp "$SRC/$f" "$DEST/"; done
[ -f "$SRC/metrics.jsonl" ] && gzip -9 -n -c "$SRC/metrics.jsonl" > "$DEST/metrics.jsonl.gz"
cd $WORK/main
for i in 1 2 3 4 5 6; do
  git add -- "$2" && git commit -q -m "$MSG" -- "$2" && break
  sleep 7
done
