#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (one NVIDIA H200, 16 cores), through the device tool, after
# benches/gpu/prepare.sh ran here. Two calls, one right after the other (the tracked tree and
# all the packed binaries together pass the call's 64 MiB):
#   1. carry [".gl", ".gpubin"], command `bash benches/gpu/device.sh gpu`, timeout_s 300:
#      issues 20 and 52, the GPU source on the H200 (per-ray traversal counters of the binary
#      and the wide BVH, primary rays/s on 1 M triangles with each BVH, dispatch cost, batch
#      curve, Cornell paths/s against the 16 CPU cores, both under the balancer and by default);
#   2. carry [".gpusim"], command `bash benches/gpu/device.sh validation`, timeout_s 330:
#      issue 21, the SimGrid validation on 16 cores (measured runs at 1-16 local workers, then
#      the simulation of the same configurations from a probe taken there).
# Each step runs under its own timeout (GPU 5 min, validation 5 min at most; 1-3 min normally).
# The wavefront split of issue 52 is not built: see docs/gpu.md for why and what the counters say.
# Everything lands in a work folder that is packed into $OUT/results.tar.gz after every step,
# so a step cut by its timeout still returns what came before it. `SMALL=1` shrinks every size
# for a dry run on lavapipe (not a measurement).
set -uo pipefail
cd "$(dirname "$0")/../.."
OUT=${OUT:-/tmp/gpu-out}
W=/tmp/raysched-device
rm -rf "$W" && mkdir -p "$OUT" "$W/gpu" "$W/validation16"
log() { echo "== $(date -u +%T) $*" | tee -a "$W/summary.txt"; }
# The kernel's CPU accounting (user … steal) at each step: steal time is what other guests of
# the host took from this one, the likeliest cause of a speed that swings between rounds.
cpustat() { echo "$(date -u +%T) $1 $(head -1 /proc/stat)" >>"$W/cpustat.txt"; }
snap() { cp "$W/summary.txt" "$OUT/" 2>/dev/null; tar -C "$W" -czf "$OUT/results.tar.gz" .; }
part=${1:-all}
small=${SMALL:-0}
PKG=.gpubin
if [ "$part" = validation ]; then PKG=.gpusim; fi
size() { if [ "$small" = 1 ]; then echo "$2"; else echo "$1"; fi; }
# The Vulkan loader (README of the device tool): unpack the carried .debs at /.
if [ "$small" != 1 ] && [ -d .gl ]; then
  for f in .gl/*.deb; do dpkg -x "$f" /; done
  ldconfig
fi
if [ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ]; then
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
B=/tmp/raysched-bin
mkdir -p $B
for f in $PKG/*.xz; do
  case $f in *.tar.xz) ;; *) b=$(basename "$f" .xz); xz -dc "$f" >"$B/$b" && chmod +x "$B/$b" ;; esac
done
# The binaries were linked here against Debian 12's glibc 2.36: an older glibc there fails now,
# with the loader's message, rather than halfway.
if ! $B/raysched --version >"$W/version.txt" 2>&1; then
  cat "$W/version.txt"; echo "the carried binaries do not run on this machine"; snap; exit 1
fi
{
  date -u
  uname -a
  ldd --version | head -1
  lscpu | grep -E 'Model name|^CPU\(s\)|MHz'
  free -g | head -2
  nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv
  cat $PKG/commit.txt 2>/dev/null
  ldconfig -p | grep libvulkan || echo "no libvulkan"
  uptime
} >"$W/machine.txt" 2>&1
cat "$W/machine.txt"
snap

# ---- 1. The GPU source (issues 20, 52) ----
if [ "$part" != validation ]; then
# Per-ray traversal counters, binary vs wide BVH, from the kernel's debug pipeline and the CPU
# walk of the same buffers (they agree ray for ray: `mismatched_rays 0`): device-independent,
# recorded here beside the timings of the same binaries. max_depth 1, 1 spp: the render after
# them is short.
for sc in complex cornell_box; do
  log "gpu-counters $sc $(size 1024 32)² primary rays"
  sed "s/^width = 128/width = $(size 1024 32)/; s/^height = 128/height = $(size 1024 32)/; s/^max_depth = .*/max_depth = 1/" \
    scenes/$sc.toml >/tmp/counters_$sc.toml
  timeout 60 $B/raysched render /tmp/counters_$sc.toml --sources gpu --gpu-counters --scheduler master \
    --spp 1 -o /tmp/counters.exr >"$W/gpu/counters_$sc.txt" 2>&1
  grep '^gpu-counters' "$W/gpu/counters_$sc.txt" | tee -a "$W/summary.txt"
  snap
done
# Primary rays/s on the 1 M-triangle scene with each BVH, one right after the other (issue 52's
# goal: ≥ 1 G rays/s with the wide one). Each builds its own BVH in its upload.
for bvh in binary wide; do
  log "gpu_dispatch complex primary rays $(size 1024 32)² $(size 4 1) spp, $bvh BVH"
  timeout 50 $B/gpu_dispatch --scene scenes/complex.toml --width "$(size 1024 32)" --spp "$(size 4 1)" \
    --max-depth 1 --min-s "$(size 0.5 0.05)" --depth-batch "$(size 262144 256)" --bvh $bvh \
    --out "$W/gpu/dispatch_complex_primary_$bvh.csv" \
    | grep -E '^(upload|rays|knee|overhead)' | tee -a "$W/summary.txt"
  snap
done
# Dispatch cost and batch-size curve on the Cornell box (1 spp, full paths, 512²); NO_DISPATCH=1
# skips both gpu_dispatch steps (a rerun of the renders alone).
if [ "${NO_DISPATCH:-0}" != 1 ]; then
log "gpu_dispatch cornell $(size 512 32)² 1 spp"
timeout 50 $B/gpu_dispatch --scene scenes/cornell_box.toml --width "$(size 512 32)" --spp 1 \
  --min-s "$(size 0.5 0.05)" --depth-batch "$(size 65536 256)" --out "$W/gpu/dispatch_cornell.csv" \
  | tail -20 | tee -a "$W/summary.txt"
snap
fi
# Paths/s on the Cornell box at 1024² (128² is far too few threads to fill an H200):
# 16 CPU threads vs the GPU vs 16 threads + the GPU under the balancer.
px=$(size 1024 32)
sed "s/^width = 128/width = $px/; s/^height = 128/height = $px/" scenes/cornell_box.toml >/tmp/cornell_big.toml
# Two interleaved passes of: 16 threads alone (16 spp: paths/s do not depend on spp); the
# GPU alone (buffer 256 tiles = 262 144 pixels a dispatch); both under the grain-picking
# balancer at 32² tiles and B = 4 (`both`); both with one grain and no balancer (`unbalanced`:
# a given --gpu-buffer turns the default balancer off); threads and GPU each with its own
# grain by hand; both with no grain flag at all (`default`: the balancer at the master's 16²
# tiles and B = 2, what a user gets). On the H200 (results/published/gpu/) one grain gave
# 0.55-0.68 of the sum of the separate rates, own grains 0.949-0.976; the simulation of that
# pair (cargo run --release --example hetero_sim, M-151) puts `default` at 0.99, `both` at
# 0.98, `unbalanced` at 0.34 and own grains at 0.98 of the summed rate.
# Paths/s of render NAME of this pass: pixels × spp / wall.
paths() { awk '/^scene /{s=$3; gsub(/[^0-9]+/," ",s); split(s,a," "); w=a[1]; h=a[2]; spp=$4+0} /^wall /{print w*h*spp/$2; exit}' "$W/gpu/render_$1_$pass.txt"; }
# render NAME SPP FLAGS...: one render of the 1024² Cornell box under the master, its output
# in render_NAME_<pass>.txt.
render() {
  local name=$1 spp=$2
  shift 2
  timeout 40 $B/raysched render /tmp/cornell_big.toml --scheduler master --spp "$spp" "$@" \
    -o /tmp/render.exr >"$W/gpu/render_${name}_$pass.txt" 2>&1
}
big=$(size 512 2)
both="--chunk 32 --sources threads,gpu --buffer 4 --gpu-buffer 256"
for pass in 1 2; do
  log "pass $pass: cpu 16 threads $(size 16 2) spp; gpu alone, both balanced, both unbalanced, default $big spp"
  render cpu "$(size 16 2)" --chunk 32 --threads 16 --buffer 4
  render gpu "$big" --chunk 32 --sources gpu --buffer 4 --gpu-buffer 256
  render both "$big" --chunk 32 --sources threads,gpu --buffer 4 --threads 16
  # shellcheck disable=SC2086
  render unbalanced "$big" $both --threads 16
  # Each source its own granularity: threads 8² tiles (about 50 ms each at 512 spp here, where
  # a 32² tile took a thread 0.3-0.9 s), the GPU 512² per hand-out (one dispatch), two in flight.
  render grain "$big" --chunk 8 --sources threads,gpu --threads 16 --buffer 2 \
    --gpu-chunk "$(size 512 16)" --gpu-buffer 2
  render default "$big" --sources threads,gpu --threads 16
  grep -E "^(wall|  worker 0 |  worker 16|  master)" "$W/gpu/render_grain_$pass.txt" "$W/gpu/render_default_$pass.txt" | tee -a "$W/summary.txt"
  c=$(paths cpu); g=$(paths gpu); b=$(paths both); u=$(paths unbalanced)
  gr=$(paths grain); df=$(paths default)
  cpustat "gpu pass $pass"
  log "paths/s: cpu16 $c, gpu $g, balanced $b, unbalanced $u, own grains $gr, default $df; of cpu+gpu: $(awk -v c="$c" -v g="$g" -v b="$b" -v u="$u" -v r="$gr" -v d="$df" 'BEGIN{if (c+g>0) print b/(c+g), u/(c+g), r/(c+g), d/(c+g); else print "n/a"}')"
  snap
done
fi

# ---- 2. The SimGrid validation on 16 cores (issue 21) ----
if [ "$part" != gpu ]; then
# SimGrid is opened at run time (dlopen): its library and dependencies travel packed.
mkdir -p /tmp/sg && tar -C /tmp/sg -xJf .gpusim/sglib.tar.xz
V=experiments/simvalidate16.toml
S=experiments/simulation_validation16.toml
if [ "$small" = 1 ]; then
  sed 's/^repetitions = 7/repetitions = 1/; s/^spp = 16/spp = 1/; s/^workers = .*/workers = [1, 2]/' $V >/tmp/simvalidate16.toml
  sed 's|\.\./|'"$PWD"'/|g; s/^spp = 16/spp = 1/; s/^workers = .*/workers = [1, 2]/' $S >/tmp/simulation_validation16.toml
  sed -i 's|^path = "\.\./|path = "'"$PWD"'/|' /tmp/simvalidate16.toml
  V=/tmp/simvalidate16.toml S=/tmp/simulation_validation16.toml
fi
cpustat "before measured"
log "measured: $V  ($(uptime))"
timeout 160 $B/raysched run $V --fresh --quiet --out results/runs >"$W/validation16/measured_log.txt" 2>&1
echo "rc=$?" >>"$W/validation16/measured_log.txt"
tail -3 "$W/validation16/measured_log.txt" | tee -a "$W/summary.txt"
cp results/runs/simvalidate16/runs.csv results/runs/simvalidate16/meta.toml "$W/validation16/" 2>/dev/null
snap
cpustat "after measured"
log "simulated: $S  ($(uptime))"
LD_LIBRARY_PATH=/tmp/sg/sglib timeout 140 $B/raysched simulate $S --out results/runs \
  >"$W/validation16/simulate_log.txt" 2>&1
echo "rc=$?" >>"$W/validation16/simulate_log.txt"
grep -E '^(probe|validation)' "$W/validation16/simulate_log.txt" | tail -70 >>"$W/summary.txt"
tail -3 "$W/validation16/simulate_log.txt"
cp -r results/runs/simulation_validation16 "$W/validation16/simulated" 2>/dev/null
fi
cpustat done
log "done ($(uptime))"
snap
ls -la "$OUT"
