#!/bin/bash
# Window C: advise_check, release build of the committed tree.
W=/tmp/adv8/win/C; mkdir -p $W
cd /work/wt-advise
B=/tmp/adv8/raysched-new
log() { echo "$(date -u +%T) $*" | tee -a $W/window.txt; }
up() { log "uptime: $(uptime)"; }
log "commit $(git rev-parse HEAD) dirty=$(git status --porcelain --untracked-files=no | wc -l)"
up
log "3. run advise_check --fresh"
timeout 300 $B run experiments/advise_check.toml --fresh --quiet --out $W > $W/advise_check.log 2>&1; log "rc $?"; up
log done
