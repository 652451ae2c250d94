#!/bin/bash
# Window A: diag9 (order over one-pixel items, 1 and 2 workers), then heterogeneous and skewed.
W=/tmp/adv9/win/A; mkdir -p $W
cd /work/wt-advise
B=/tmp/adv9/raysched
log() { echo "$(date -u +%T) $*" | tee -a $W/window.txt; }
up() { log "uptime: $(uptime)"; }
log "commit $(git rev-parse HEAD) dirty=$(git status --porcelain --untracked-files=no | wc -l)"
log "lscpu: $(lscpu | grep -E 'Model name|^CPU\(s\)|Thread' | tr -s ' ' | tr '\n' ';')"
up
log "1. diag9"
timeout 150 $B run /tmp/adv9/diag9.toml --fresh --quiet --out $W/diag > $W/diag.log 2>&1; log "rc $?"; up
log "2. heterogeneous"
timeout 120 $B run experiments/heterogeneous.toml --fresh --quiet --out $W > $W/heterogeneous.log 2>&1; log "rc $?"; up
log "3. skewed"
timeout 240 $B run experiments/skewed.toml --fresh --quiet --out $W > $W/skewed.log 2>&1; log "rc $?"; up
log done
