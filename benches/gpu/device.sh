#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (one NVIDIA H200, 16 cores), through the device tool, after
# benches/gpu/prepare.sh ran here:  carry [".gl", ".gpubin"], command `bash benches/gpu/device.sh`,
# timeout_s 400 (every step has its own timeout, 330 s in all; a normal run takes 2-3 minutes,
# leaving device time to rerun once).
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
# The binaries were linked here against Debian 12's glibc 2.36: an older glibc there fails now,
# with the loader's message, rather than halfway.
if ! $B/raysched --version >"$OUT/version.txt" 2>&1; then
  cat "$OUT/version.txt"; echo "the carried binaries do not run on this machine"; exit 1
fi
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
timeout 60 $B/gpu_dispatch --scene scenes/cornell_box.toml --width 512 --spp 1 --min-s 0.5 \
  --depth-batch 65536 --out "$OUT/gpu_dispatch_cornell.csv" | tail -20 | tee -a "$OUT/summary.txt"
# 2. Primary rays on the 1 M-triangle scene: max_depth 1, 1024², 4 spp (4 M rays a dispatch).
log "gpu_dispatch complex (1 M triangles) primary rays 1024² 4 spp"
timeout 90 $B/gpu_dispatch --scene scenes/complex.toml --width 1024 --spp 4 --max-depth 1 \
  --min-s 0.5 --depth-batch 262144 --out "$OUT/gpu_dispatch_complex_primary.csv" \
  | grep -E '^(upload|rays|knee|overhead)' | tee -a "$OUT/summary.txt"
# 3. Paths/s on the Cornell box at 1024² (128² is far too few threads to fill an H200):
#    16 CPU threads vs the GPU vs 16 threads + the GPU under the balancer.
sed 's/^width = 128/width = 1024/; s/^height = 128/height = 1024/' scenes/cornell_box.toml >/tmp/cornell_1024.toml
R="$B/raysched render /tmp/cornell_1024.toml --scheduler master --chunk 32"
log "cpu 16 threads, 128 spp"
timeout 60 $R --spp 128 --threads 16 --buffer 4 -o /tmp/cpu.exr 2>&1 | tee "$OUT/render_cpu.txt" | grep -E '^wall'
log "gpu alone, 512 spp (gpu buffer 256 tiles = 262 144 pixels a dispatch)"
timeout 60 $R --spp 512 --sources gpu --buffer 4 --gpu-buffer 256 -o /tmp/gpu.exr 2>&1 | tee "$OUT/render_gpu.txt" | grep -E '^(wall|scene|sched|  worker)'
log "16 threads + gpu, balancer on, 512 spp"
timeout 60 $R --spp 512 --sources threads,gpu --threads 16 --buffer 4 --gpu-buffer 256 --balance -o /tmp/both.exr 2>&1 \
  | tee "$OUT/render_both.txt" | grep -E '^(wall|  worker|  master)'
# Paths/s = pixels × spp / wall for each render; the balanced run against the sum of the two.
paths() { awk '/^scene /{s=$3; gsub(/[^0-9]+/," ",s); split(s,a," "); w=a[1]; h=a[2]; spp=$4+0} /^wall /{print w*h*spp/$2}' "$1"; }
c=$(paths "$OUT/render_cpu.txt"); g=$(paths "$OUT/render_gpu.txt"); b=$(paths "$OUT/render_both.txt")
log "paths/s: cpu16 $c, gpu $g, threads+gpu $b; (threads+gpu)/(cpu+gpu) = $(awk -v c="$c" -v g="$g" -v b="$b" 'BEGIN{if (c+g>0) print b/(c+g); else print "n/a"}')"
log "done"
ls -la "$OUT"
