#!/bin/bash
cd /work/main
B=target/release/raysched
echo "measured start $(date -u +%T) $(uptime)"
$B run experiments/simvalidate.toml --fresh --out /tmp/val/measured > /tmp/val/measured.log 2>&1
echo "measured end $(date -u +%T) rc=$?"
for k in 0 3 0 3; do
  echo "sim l$k start $(date -u +%T) $(uptime)"
  $B simulate /tmp/val/sv_l$k.toml --out /tmp/val/sim_l$k > /tmp/val/sim_l$k.log 2>&1
  echo "rc=$?"; mkdir -p /tmp/val/keep; cp -r /tmp/val/sim_l$k /tmp/val/keep/sim_l${k}_$(date +%s)
done
echo "done $(date -u +%T)"
