#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (one NVIDIA H200, 16 cores), through the device tool, after
# benches/gpu/prepare.sh ran here:  carry [".gl", ".gpubin"], command `bash benches/gpu/device.sh`,
# timeout_s 420 (the whole script is sized for ~5 minutes, leaving time to rerun once).
# Writes under $OUT: machine.txt (metadata), gpu_dispatch_*.csv, render_*.txt, summary.txt.
set -uo pipefail
cd "$(dirname "$0")/../.."
OUT=${OUT:-/tmp/gpu-out}
mkdir -p "$OUT"
log() { echo "== $*" | tee -a "$OUT/summary.txt"; }
# The Vulkan loader (README of the device tool): unpack the carried .debs at /.
for f in .gl/*.deb; do dpkg -x "$f" /; done
ldconfig
if [ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ]; then
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
B=.gpubin
{
  date -u
  uname -a
  ldd --version | head -1
  lscpu | grep -E 'Model name|^CPU\(s\)'
  nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv
  git log -1 --format='commit %H %s' 2>/dev/null || true
  ldconfig -p | grep libvulkan || echo "no libvulkan"
} >"$OUT/machine.txt" 2>&1
cat "$OUT/machine.txt"
# 1. Dispatch cost and batch-size curve on the Cornell box (1 spp, full paths, 512²).
log "gpu_dispatch cornell 512² 1 spp"
timeout 90 $B/gpu_dispatch --scene scenes/cornell_box.toml --width 512 --spp 1 --min-s 0.5 \
  --depth-batch 65536 --out "$OUT/gpu_dispatch_cornell.csv" | tail -20 | tee -a "$OUT/summary.txt"
# 2. Primary rays on the 1 M-triangle scene: max_depth 1, 1024², 4 spp (4 M rays a dispatch).
log "gpu_dispatch complex (1 M triangles) primary rays 1024² 4 spp"
timeout 120 $B/gpu_dispatch --scene scenes/complex.toml --width 1024 --spp 4 --max-depth 1 \
  --min-s 0.5 --depth-batch 262144 --out "$OUT/gpu_dispatch_complex_primary.csv" \
  | grep -E '^(upload|rays|knee|overhead)' | tee -a "$OUT/summary.txt"
# 3. Paths/s on the Cornell box (512², 16 spp): 16 CPU threads vs the GPU vs both balanced.
R="$B/raysched render scenes/cornell_box.toml --spp 16 --scheduler master --chunk 16"
log "cpu 16 threads"
timeout 90 $R --threads 16 --buffer 4 -o /tmp/cpu.exr 2>&1 | tee "$OUT/render_cpu.txt" | grep -E '^wall'
log "gpu alone (gpu buffer 256 tiles)"
timeout 90 $R --sources gpu --buffer 4 --gpu-buffer 256 -o /tmp/gpu.exr 2>&1 | tee "$OUT/render_gpu.txt" | grep -E '^(wall|source|scene|sched)'
log "threads + gpu, balancer on"
timeout 90 $R --sources threads,gpu --threads 15 --buffer 4 --gpu-buffer 256 --balance -o /tmp/both.exr 2>&1 \
  | tee "$OUT/render_both.txt" | grep -E '^(wall|source|balancer)'
# Paths/s = pixels × spp / wall for each render; the balanced run against the sum of the two.
paths() { awk '/^scene /{s=$3; gsub(/[^0-9]+/," ",s); split(s,a," "); w=a[1]; h=a[2]; spp=$4+0} /^wall /{print w*h*spp/$2}' "$1"; }
c=$(paths "$OUT/render_cpu.txt"); g=$(paths "$OUT/render_gpu.txt"); b=$(paths "$OUT/render_both.txt")
log "paths/s: cpu16 $c, gpu $g, threads+gpu $b; (threads+gpu)/(cpu+gpu) = $(awk -v c="$c" -v g="$g" -v b="$b" 'BEGIN{if (c+g>0) print b/(c+g); else print "n/a"}')"
log "done"
ls -la "$OUT"
