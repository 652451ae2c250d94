#!/bin/bash
# Window G: order and rule apart at one-pixel items (diag2.toml), new binary, once.
W=/tmp/adv8/win/G; mkdir -p $W
cd /work/wt-advise
log() { echo "$(date -u +%T) $*" | tee -a $W/window.txt; }
up() { log "uptime: $(uptime)"; }
up
timeout 240 /tmp/adv8/raysched-new run /tmp/adv8/diag/diag2.toml --fresh --quiet --out $W > $W/diag2.log 2>&1; log "diag2 rc $?"; up
log done
