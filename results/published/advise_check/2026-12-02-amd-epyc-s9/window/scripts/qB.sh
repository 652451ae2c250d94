#!/bin/bash
# Window B: advise_check.
W=/tmp/adv9/win/B; mkdir -p $W
cd /work/wt-advise
B=/tmp/adv9/raysched
log() { echo "$(date -u +%T) $*" | tee -a $W/window.txt; }
up() { log "uptime: $(uptime)"; }
log "commit $(git rev-parse HEAD) dirty=$(git status --porcelain --untracked-files=no | wc -l)"
up
log "1. advise_check"
timeout 300 $B run experiments/advise_check.toml --fresh --quiet --out $W > $W/advise_check.log 2>&1; log "rc $?"; up
log done
