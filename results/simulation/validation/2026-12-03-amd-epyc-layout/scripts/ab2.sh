#!/bin/bash
cd /work/main
B=target/release/raysched
for round in 1 2; do
  echo "measured r$round start $(date -u +%T) $(cat /proc/loadavg)"
  $B run experiments/simvalidate.toml --fresh --out /tmp/val/measured > /tmp/val/measured_r$round.log 2>&1
  mkdir -p /tmp/val/keep2/m$round; cp /tmp/val/measured/simvalidate/runs.csv /tmp/val/keep2/m$round/
  order="0 3"; [ $round = 2 ] && order="3 0"
  for k in $order; do
    echo "sim r$round l$k start $(date -u +%T) $(cat /proc/loadavg)"
    $B simulate /tmp/val/sv_l$k.toml --out /tmp/val/sim_l$k > /tmp/val/sim_l$k.log 2>&1
    echo "rc=$?"; cp -r /tmp/val/sim_l$k/sv_l$k /tmp/val/keep2/r${round}_l$k
  done
done
echo "done $(date -u +%T) $(cat /proc/loadavg)"
