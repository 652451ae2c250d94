#!/usr/bin/env python3
"""The three comparisons against the peers in one command, each interleaved, with ratios.

1. Renderer: raysched against Mitsuba 3 ``llvm_ad_rgb`` on the reference Cornell box, one core
   each (``mitsuba.py``, renders alternated; skipped with a note where Mitsuba is missing).
2. Primary rays: the native BVH against Embree 3 on the 1 M-triangle ``complex`` scene at
   1024², one thread (``examples/tracer_ab``: both tracers in one process, rounds alternated;
   the best rate of each per process, the ratio per process).
3. Build and memory: one process per tracer, native and Embree alternated, each loading the
   scene and building one tracer (``tracer_ab --build-only --threads 2``): build time and the
   process's peak resident memory, at 1 M and 4 M triangles, the ratio pair by pair.

Printed first: the CPU, its vector ISA, and which path each program takes on it (raysched's
``bvh`` prints its own; Embree's is its highest target, from its verbose device report).
Ratios are raysched / peer: below 1 is raysched faster or smaller, except for rays/s
(``Mrays/s`` ratio above 1 is raysched faster). Each ratio is median (min-max) over the runs.

Setup once (not part of CI): ``bash benches/peers/setup.sh`` (Mitsuba), Debian's
``libembree-dev`` (Embree 3), then

    cargo build --release --features embree --bin raysched --example tracer_ab
    python3 benches/peers/peers.py
"""

import argparse
import ctypes
import os
import re
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def spread(xs):
    """median (min-max) of a list of ratios."""
    return f"{statistics.median(xs):.2f} ({min(xs):.2f}-{max(xs):.2f})"


def machine():
    """CPU model, the vector extensions that matter here, and the load."""
    model, flags = "?", set()
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name") and model == "?":
                model = line.split(":", 1)[1].strip()
            elif line.startswith("flags") and not flags:
                flags = set(line.split(":", 1)[1].split())
    isa = [x for x in ("avx2", "fma", "avx512f", "avx512vl", "avx512bw", "avx512dq") if x in flags]
    load = open("/proc/loadavg").read().split()[:3]
    return f"{model}, {os.cpu_count()} CPUs, ISA {' '.join(isa) or 'sse only'}, load {' '.join(load)}"


def embree_isa():
    """Embree 3's best compiled-in target this CPU supports (what it traverses with)."""
    code = (
        "import ctypes; l = ctypes.CDLL('libembree3.so.3'); "
        "l.rtcNewDevice.restype = ctypes.c_void_p; l.rtcNewDevice(b'verbose=1')"
    )
    try:
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             timeout=60).stdout
    except (OSError, subprocess.TimeoutExpired):
        return "unknown (libembree3 not loadable)"
    m = re.search(r"Targets\s*:\s*(.*)\(supported\)", out)
    return m.group(1).split()[-1].lower() if m else "unknown"


def run(cmd):
    out = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    if out.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: exit {out.returncode}\n{out.stderr.strip()}")
    return out.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release"),
                    help="folder of raysched and examples/tracer_ab (release, --features embree)")
    ap.add_argument("--runs", type=int, default=3, help="processes of each tracer per size")
    ap.add_argument("--counts", default="1000000,4000000", help="triangle counts of the build")
    ap.add_argument("--side", type=int, default=1024, help="image side of the primary rays")
    ap.add_argument("--rounds", type=int, default=5, help="alternated rounds per ray process")
    ap.add_argument("--renders", type=int, default=5, help="timed Cornell renders of each")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--skip", default="", help="comma list of: render, rays, build")
    args = ap.parse_args()
    skip = set(filter(None, args.skip.split(",")))
    ab = os.path.join(args.bin, "examples", "tracer_ab")
    if not os.path.exists(ab):
        sys.exit(f"{ab}: not built (cargo build --release --features embree --example tracer_ab)")

    print(f"machine: {machine()}")
    path = re.search(r"path bvh: (\S+)",
                     run([ab, "--build-only", "complex", "20000", "16", "1", "bvh"]))
    print(f"paths: raysched bvh {path.group(1) if path else '?'}; Embree 3 {embree_isa()}; "
          "Mitsuba llvm_ad_rgb: Dr.Jit's LLVM backend, vectorised across paths at the host's "
          "widest ISA")

    if "render" not in skip:
        print("\n[1] renderer against Mitsuba 3 llvm_ad_rgb (Cornell box, one core each)",
              flush=True)
        try:
            import importlib.util
            have = importlib.util.find_spec("mitsuba") is not None
        except ImportError:
            have = False
        if not have:
            print("  skipped: no `mitsuba` module (bash benches/peers/setup.sh)")
        else:
            out = run([sys.executable, os.path.join(ROOT, "benches", "peers", "mitsuba.py"),
                       "--variants", "llvm_ad_rgb", "--renders", str(args.renders),
                       "--spp", str(args.spp), "--raysched", os.path.join(args.bin, "raysched")])
            print("  " + out.strip().replace("\n", "\n  "))

    if "rays" not in skip:
        print(f"\n[2] primary rays against Embree 3 (complex, 1 M triangles, {args.side}², "
              f"one thread, {args.runs} processes of {args.rounds} alternated rounds)",
              flush=True)
        # The native tracer on its widest path, and stepped down to AVX2 where that is wider
        # than AVX2, in the same processes.
        ids = ["bvh"] + (["bvh@avx2"] if path and path.group(1) == "avx512" else []) + ["embree"]
        rates = {i: [] for i in ids}
        for _ in range(args.runs):
            out = run([ab, "--rays", "primary", "complex", "1000000", str(args.side),
                       str(args.rounds)] + ids)
            for m in re.finditer(r", (\S+): best ([\d.]+) Mrays/s", out):
                rates[m.group(1)].append(float(m.group(2)))
        for i in ids:
            print(f"  {i}: best rate per process {spread(rates[i])} Mrays/s")
        for i in ids[:-1]:
            ratio = [b / e for b, e in zip(rates[i], rates["embree"])]
            print(f"  ratio rays/s {i} / embree: {spread(ratio)} (goal >= 1.00)")

    if "build" not in skip:
        print(f"\n[3] build and peak memory against Embree 3 (one process per tracer, "
              f"--threads 2, {args.runs} alternated pairs)", flush=True)
        for count in args.counts.split(","):
            got = {"bvh": [], "embree": []}
            for _ in range(args.runs):
                for tracer in ("bvh", "embree"):
                    out = run([ab, "--build-only", "--threads", "2", "complex", count, "16",
                               "1", tracer])
                    s = float(re.search(rf"build {tracer}: ([\d.]+) s", out).group(1))
                    mib = float(re.search(r"peak_rss_mib ([\d.]+)", out).group(1))
                    got[tracer].append((s, mib))
            pairs = list(zip(got["bvh"], got["embree"]))
            build = [b[0] / e[0] for b, e in pairs]
            rss = [b[1] / e[1] for b, e in pairs]
            med = lambda k, i: statistics.median(x[i] for x in got[k])
            print(f"  {int(count):,} triangles: build bvh {med('bvh', 0):.3f} s, embree "
                  f"{med('embree', 0):.3f} s, ratio {spread(build)}; peak RSS bvh "
                  f"{med('bvh', 1):.0f} MiB, embree {med('embree', 1):.0f} MiB, ratio "
                  f"{spread(rss)} (goals <= 1.00)")


if __name__ == "__main__":
    main()
