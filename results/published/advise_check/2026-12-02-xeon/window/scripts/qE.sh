#!/bin/bash
# Window E: per-item cost in a run, old vs new binary alternated twice (diag.toml).
W=/tmp/adv8/win/E; mkdir -p $W
cd /work/wt-advise
OLD=/tmp/adv8/raysched-old NEW=/tmp/adv8/raysched-new
log() { echo "$(date -u +%T) $*" | tee -a $W/window.txt; }
up() { log "uptime: $(uptime)"; }
up
for k in 1 2; do
  for b in OLD NEW; do
    bin=${!b}
    timeout 120 $bin run /tmp/adv8/diag/diag.toml --fresh --quiet --out $W/${b}_$k > $W/${b}_$k.log 2>&1; log "diag $b $k rc $?"; up
  done
done
log done
