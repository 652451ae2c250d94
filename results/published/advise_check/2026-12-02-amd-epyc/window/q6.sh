#!/bin/bash
cd /work/wt-advise
W=/tmp/adv7/win2
B=./target-rel/release/raysched
log() { echo "$(date -u +%T) $*" | tee -a $W/window.txt; }
up() { log "uptime: $(uptime)"; }
log "commit $(git rev-parse HEAD) dirty=$(git status --porcelain --untracked-files=no | wc -l)"
up
log "3. run advise_check --fresh"
timeout 200 $B run experiments/advise_check.toml --fresh --quiet --out $W > $W/advise_check.log 2>&1; log "rc $?"; up
log "done"
