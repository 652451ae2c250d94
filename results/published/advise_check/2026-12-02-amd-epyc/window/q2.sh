#!/bin/bash
# Q2: AF per-item vs per-group clock A/B (base binary vs new), AWF/AF/WF timelines, master per-ray r.
cd /work/wt-advise
NEW=./target-rel/release/raysched
OLD=/tmp/adv7/raysched-base
O=/tmp/adv7/q2
mkdir -p $O
up() { echo "$(date -u +%T) uptime: $(uptime)"; }
up
for k in 1 2; do
  for b in OLD NEW; do
    bin=${!b}
    timeout 60 $bin run /tmp/adv7/ab.toml --fresh --quiet --out $O/ab_${b}_$k > $O/ab_${b}_$k.log 2>&1; echo "ab $b $k rc $?"; up
  done
done
timeout 40 $NEW run /tmp/adv7/tl_het.toml --fresh --quiet --out $O > $O/tl.log 2>&1; echo "tl rc $?"; up
for i in 1 2; do
  timeout 60 $NEW advise scenes/cornell_box.toml --spp 8 --scheduler master,self_scheduling --chunks 1,4 > $O/advise_cornell_$i.txt 2>&1; echo "advise rc $?"; up
  for s in master self_scheduling; do
    $NEW render scenes/cornell_box.toml --spp 8 --scheduler $s --chunk 1 --threads 2 -o $O/r.exr >> $O/render_cornell.txt 2>&1
  done
done
up
