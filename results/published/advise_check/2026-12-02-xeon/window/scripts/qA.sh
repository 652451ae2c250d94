#!/bin/bash
# Window A: per-item cost, old (base 90cdc7d) vs new render_item bench binaries alternated 3×.
W=/tmp/adv8/win/A; mkdir -p $W
OLD=/tmp/adv8/render-old NEW=/tmp/adv8/render-new
log() { echo "$(date -u +%T) $*" | tee -a $W/window.txt; }
up() { log "uptime: $(uptime)"; }
log "lscpu: $(lscpu | grep -E 'Model name|^CPU\(s\)|Thread' | tr -s ' ' | tr '\n' ';')"
up
cd /work/wt-advise
for k in 1 2 3; do
  for b in OLD NEW; do
    bin=${!b}
    timeout 60 $bin --bench item_cost --noplot --discard-baseline > $W/bench_${b}_$k.txt 2>&1; log "bench $b $k rc $?"; up
  done
done
log done
