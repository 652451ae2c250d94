#!/bin/bash
# Window F: where a one-pixel item's cost goes (new bench binary, twice): plain, results kept, scatter order.
W=/tmp/adv8/win/F; mkdir -p $W
cd /work/wt-advise
log() { echo "$(date -u +%T) $*" | tee -a $W/window.txt; }
up() { log "uptime: $(uptime)"; }
up
for k in 1 2; do
  timeout 90 /tmp/adv8/render-new2 --bench item_cost --noplot --discard-baseline > $W/bench_$k.txt 2>&1; log "bench $k rc $?"; up
done
log done
