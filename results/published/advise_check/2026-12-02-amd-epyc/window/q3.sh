#!/bin/bash
# The advise publish window (session 7): advise_check, skewed, heterogeneous with the committed
# tree's release build, each step timed with uptime.
cd /work/wt-advise
W=/tmp/adv7/win
mkdir -p $W
B=./target-rel/release/raysched
log() { echo "$(date -u +%T) $*" | tee -a $W/window.txt; }
up() { log "uptime: $(uptime)"; }
log "commit $(git rev-parse HEAD) dirty=$(git status --porcelain --untracked-files=no | wc -l)"
log "lscpu: $(lscpu | grep -E 'Model name|^CPU\(s\)|Thread' | tr -s ' ' | tr '\n' ';')"
up
log "1. run advise_check --fresh"
timeout 200 $B run experiments/advise_check.toml --fresh --quiet --out $W > $W/advise_check.log 2>&1; log "rc $?"; up
log "2. run heterogeneous --fresh"
timeout 90 $B run experiments/heterogeneous.toml --fresh --quiet --out $W > $W/heterogeneous.log 2>&1; log "rc $?"; up
log "done"
