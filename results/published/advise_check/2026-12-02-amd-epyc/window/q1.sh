#!/bin/bash
cd /work/wt-advise
B=./target-rel/release/raysched
echo "$(date -u +%T) uptime: $(uptime)"
timeout 150 $B run /tmp/adv7/diag_het.toml --fresh --quiet --out /tmp/adv7/q1 ; echo "rc $?"
echo "$(date -u +%T) uptime: $(uptime)"
timeout 120 $B run /tmp/adv7/diag_skew.toml --fresh --quiet --out /tmp/adv7/q1 ; echo "rc $?"
echo "$(date -u +%T) uptime: $(uptime)"
