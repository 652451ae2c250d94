#!/bin/bash
# The advise quiet window, 01:25–01:40 UTC. Release build of the committed tree.
cd /work/wt-advise
W=/tmp/adv/win
B=./target/release/raysched
END=$(date -u -d "01:39:30" +%s)
log() { echo "$(date -u +%T) $*" | tee -a $W/window.txt; }
up() { log "uptime: $(uptime)"; }
left() { echo $(( END - $(date -u +%s) )); }
echo "$(date -u +%H:%M) advise start window" >> /work/notes/windows.log
log "commit $(git rev-parse HEAD) dirty=$(git status --porcelain --untracked-files=no | wc -l)"
log "lscpu: $(lscpu | grep -E 'Model name|^CPU\(s\)|Thread' | tr -s ' ' | tr '\n' ';')"
up
log "1. refill_probe 100 300 1000 3000 (spinning items, master B=2 vs self_scheduling, P=2)"
timeout 60 nice -n 0 ./target/release/examples/refill_probe 100 300 1000 3000 > $W/refill_probe.txt 2>&1; up
log "2. skewed_x100 16 spp chunk 16: master vs self_scheduling x4 each, stats"
for i in 1 2 3 4; do for s in self_scheduling master; do $B render scenes/skewed_x100.toml --spp 16 --scheduler $s --chunk 16 -o $W/r.exr >> $W/master16.txt 2>&1; done; done; up
log "2b. run master16 (skewed_x100 16², master B=1,2,4 vs self_scheduling 4², 16², timelines)"
timeout 60 $B run /tmp/adv/master16.toml --fresh --quiet --out $W > $W/master16.log 2>&1; log "rc $?"; up
python3 /tmp/adv/gaps.py $W/master16 > $W/master16_gaps.txt 2>&1
log "3. run advise_check --fresh"
timeout $(left) $B run experiments/advise_check.toml --fresh --quiet --out $W/r1 > $W/advise_check.log 2>&1; log "rc $?"; up
log "4. run skewed --fresh"
timeout $(left) $B run experiments/skewed.toml --fresh --quiet --out $W > $W/skewed.log 2>&1; log "rc $?"; up
log "5. run heterogeneous --fresh"
timeout $(left) $B run experiments/heterogeneous.toml --fresh --quiet --out $W > $W/heterogeneous.log 2>&1; log "rc $?"; up
if [ $(left) -gt 150 ]; then
  log "6. run advise_check --fresh (run 2)"
  timeout $(left) $B run experiments/advise_check.toml --fresh --quiet --out $W/r2 > $W/advise_check2.log 2>&1; log "rc $?"; up
fi
echo "$(date -u +%H:%M) advise end window" >> /work/notes/windows.log
log "done"
