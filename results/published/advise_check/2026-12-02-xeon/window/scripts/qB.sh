#!/bin/bash
# Window B: heterogeneous and skewed sweeps, release build of the committed tree.
W=/tmp/adv8/win/B; mkdir -p $W
cd /work/wt-advise
B=/tmp/adv8/raysched-new
log() { echo "$(date -u +%T) $*" | tee -a $W/window.txt; }
up() { log "uptime: $(uptime)"; }
log "commit $(git rev-parse HEAD) dirty=$(git status --porcelain --untracked-files=no | wc -l)"
log "lscpu: $(lscpu | grep -E 'Model name|^CPU\(s\)|Thread' | tr -s ' ' | tr '\n' ';')"
up
log "1. run heterogeneous --fresh"
timeout 150 $B run experiments/heterogeneous.toml --fresh --quiet --out $W > $W/heterogeneous.log 2>&1; log "rc $?"; up
log "2. run skewed --fresh"
timeout 300 $B run experiments/skewed.toml --fresh --quiet --out $W > $W/skewed.log 2>&1; log "rc $?"; up
log done
