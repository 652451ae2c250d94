#!/bin/bash
# Window D: the advise probe's per-item cost c, old vs new binary, alternated twice, two scenes.
W=/tmp/adv8/win/D; mkdir -p $W
cd /work/wt-advise
OLD=/tmp/adv8/raysched-old NEW=/tmp/adv8/raysched-new
log() { echo "$(date -u +%T) $*" | tee -a $W/window.txt; }
up() { log "uptime: $(uptime)"; }
up
for k in 1 2; do
  for b in OLD NEW; do
    bin=${!b}
    for s in cornell_box skewed_low; do
      timeout 60 $bin advise scenes/$s.toml --scheduler self_scheduling --chunks 1,4 > $W/advise_${s}_${b}_$k.txt 2>&1; log "advise $s $b $k rc $?"
    done
    up
  done
done
log done
