#!/usr/bin/env python3
"""raysched against Mitsuba 3 on the reference Cornell box, one core each, interleaved.

Mitsuba renders its built-in ``mi.cornell_box()`` with the reference settings of
docs/conventions.md (box reconstruction filter instead of the stock 2-px Gaussian, max_depth 8,
128x128); raysched renders ``scenes/cornell_box.toml``, the same scene. Both are pinned to one
core with ``taskset``; Dr.Jit's own thread pool is set to one thread. Each Mitsuba variant runs
in one long-lived child process that renders once untimed first (the LLVM backend compiles its
kernels then) and afterwards renders on request, so that Mitsuba renders and raysched renders
alternate: A B A B ...; a drift of the machine's speed then hits both alike.

Printed: ms per sample per pixel (ms/spp: render wall time / spp) of every render, the median,
minimum and maximum of each program, and the ratio raysched / Mitsuba pair by pair (median and
range). raysched's time is the render's wall time as it prints it (scene load and BVH build
excluded, as Mitsuba's scene load is); its process wall time is printed beside it.

Measured (quiet 2-core Intel Xeon with AVX-512, 2026-12-02 16:55, SAH collapse on big
scenes, Cornell tree unchanged): raysched / llvm_ad_rgb median 1.66 (1.64-1.68), base 1.66.
Measured (2-core AMD EPYC, 2026-12-02 07:00, 8-lane leaf test, 2 runs): raysched /
llvm_ad_rgb medians 1.69, 1.69 (1.46-1.76); the base binary in the same runs 1.74, 1.75.
Measured (quiet 2-core Intel Xeon with AVX-512, 2026-12-02, AVX node test): raysched /
llvm_ad_rgb medians 1.68, 1.71, 1.67 (1.59-1.78); raysched / scalar_rgb 0.59.
Measured (quiet 2-core AMD EPYC, 64 spp, 5 renders each, three runs, 8-wide BVH): raysched /
llvm_ad_rgb median 1.06 (0.90-1.12), 1.07 (1.01-1.13), 1.02 (0.91-1.06), raysched 19.3-23.3
ms/spp (medians) against 18.8-21.7; raysched / scalar_rgb 0.58 (0.53-0.63). The binary with
4-wide nodes, same window: 1.24 (1.12-1.45) and 1.26 (1.19-1.28). Table:
benches/peers/results.md.

Setup (once; not part of CI): see benches/peers/README.md, or ``bash benches/peers/setup.sh``.

    cargo build --release
    python3 benches/peers/mitsuba.py --variants llvm_ad_rgb,scalar_rgb --renders 5 --spp 64
"""

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# Candidates for the LLVM shared library Dr.Jit's llvm variants load (Debian's libllvm19).
LLVM_CANDIDATES = [
    "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1",
    "/usr/lib/x86_64-linux-gnu/libLLVM-19.so",
    "/usr/lib/llvm-19/lib/libLLVM-19.so",
    "/usr/lib/llvm-19/lib/libLLVM.so.1",
]


def child(variant, spp, size, max_depth):
    """Mitsuba side: load the scene, render once untimed, then one timed render per stdin line."""
    # This file is itself named mitsuba.py: import the package, not this script.
    here = os.path.dirname(os.path.abspath(__file__))
    sys.path[:] = [p for p in sys.path if os.path.abspath(p or ".") != here]
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(variant)
    if hasattr(dr, "set_thread_count"):
        dr.set_thread_count(1)
    d = mi.cornell_box()
    d["sensor"]["film"]["width"] = size
    d["sensor"]["film"]["height"] = size
    d["sensor"]["film"]["rfilter"] = {"type": "box"}
    d["sensor"]["sampler"]["sample_count"] = spp
    d["integrator"]["max_depth"] = max_depth
    scene = mi.load_dict(d)
    img = mi.render(scene, spp=spp, seed=0)
    dr.eval(img)
    print(json.dumps({"ready": True}), flush=True)
    k = 0
    while True:
        line = sys.stdin.readline()
        if not line:
            break
        k += 1
        t0 = time.perf_counter()
        img = mi.render(scene, spp=spp, seed=k)
        dr.eval(img)
        dr.sync_thread()
        s = time.perf_counter() - t0
        print(json.dumps({"s": s}), flush=True)


def start_mitsuba(variant, args):
    env = dict(os.environ)
    if "llvm" in variant and "DRJIT_LIBLLVM_PATH" not in env:
        for c in LLVM_CANDIDATES:
            if os.path.exists(c):
                env["DRJIT_LIBLLVM_PATH"] = c
                break
    cmd = ["taskset", "-c", str(args.core), sys.executable, os.path.abspath(__file__),
           "--child", variant, "--spp", str(args.spp), "--size", str(args.size),
           "--max-depth", str(args.max_depth)]
    p = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env)
    line = p.stdout.readline()
    if not line:
        sys.exit(f"mitsuba {variant}: the child exited before its first render "
                 f"(is mitsuba installed; for llvm variants, is libllvm19 there? see setup.sh)")
    return p


def mitsuba_render(p):
    p.stdin.write("go\n")
    p.stdin.flush()
    return json.loads(p.stdout.readline())["s"]


def raysched_render(args, binary):
    cmd = ["taskset", "-c", str(args.core), binary, "render",
           os.path.join(ROOT, "scenes", "cornell_box.toml"), "--threads", "1",
           "--spp", str(args.spp), "--tracer", args.tracer,
           "-o", os.path.join(args.tmp, "raysched_peer.exr")]
    t0 = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if out.returncode != 0:
        sys.exit(f"raysched failed ({out.returncode}): {out.stderr.strip()}")
    m = re.search(r"wall ([0-9.]+) s", out.stdout)
    if not m:
        sys.exit(f"raysched printed no 'wall … s' line:\n{out.stdout}")
    return float(m.group(1)), wall


def spread(v):
    return f"median {statistics.median(v):.2f}, min {min(v):.2f}, max {max(v):.2f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--variants", default="llvm_ad_rgb,scalar_rgb")
    ap.add_argument("--renders", type=int, default=5, help="timed renders of each program")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--max-depth", type=int, default=8)
    ap.add_argument("--core", type=int, default=0, help="the one CPU both programs run on")
    ap.add_argument("--raysched", default=os.path.join(ROOT, "target", "release", "raysched"),
                    help="raysched binary, or several separated by commas (e.g. a new and an "
                         "old build): each renders after every Mitsuba render, in this order")
    ap.add_argument("--tracer", default="bvh")
    ap.add_argument("--tmp", default="/tmp")
    args = ap.parse_args()
    if args.child:
        child(args.child, args.spp, args.size, args.max_depth)
        return
    if args.size != 128 or args.max_depth != 8:
        print("note: raysched renders scenes/cornell_box.toml at 128², max_depth 8 whatever "
              "--size/--max-depth say", file=sys.stderr)
    binaries = args.raysched.split(",")
    for b in binaries:
        if not os.access(b, os.X_OK):
            sys.exit(f"--raysched {b}: not an executable (cargo build --release)")
    for variant in args.variants.split(","):
        p = start_mitsuba(variant, args)
        for b in binaries:
            raysched_render(args, b)  # untimed, as Mitsuba's first render
        mts = []
        rs = {b: [] for b in binaries}
        rs_proc = {b: [] for b in binaries}
        for _ in range(args.renders):
            mts.append(mitsuba_render(p) * 1e3 / args.spp)
            for b in binaries:
                r, w = raysched_render(args, b)
                rs[b].append(r * 1e3 / args.spp)
                rs_proc[b].append(w * 1e3 / args.spp)
        p.stdin.close()
        p.wait()
        print(f"Cornell box {args.size}², {args.spp} spp, max_depth {args.max_depth}, "
              f"one core (taskset -c {args.core}), {args.renders} interleaved renders each")
        print(f"  mitsuba {variant}: ms/spp " + " ".join(f"{x:.2f}" for x in mts)
              + f"  ({spread(mts)})")
        for b in binaries:
            ratios = [a / m for a, m in zip(rs[b], mts)]
            print(f"  raysched {args.tracer} ({b}): ms/spp "
                  + " ".join(f"{x:.2f}" for x in rs[b])
                  + f"  ({spread(rs[b])}); process wall {spread(rs_proc[b])}")
            print(f"  ratio raysched / mitsuba {variant}: {spread(ratios)}", flush=True)


if __name__ == "__main__":
    main()
