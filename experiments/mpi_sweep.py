#!/usr/bin/env python3
"""Drive the MPI experiment: one `mpirun -n K raysched run EXPERIMENT` per (ranks, transport)
of its [mpi] table; each launch appends its rows to OUT/<name>/runs.csv (the serial and
local-thread baselines are measured by the first launch that needs them) and redraws the plots
and report.md.

    python3 experiments/mpi_sweep.py [experiments/mpi.toml] [--fresh] [--out results/runs]
        [--spin results/runs_spin]

With --spin DIR, every launch is made once more, right after it, into DIR, with workers that
spin instead of rendering: each pixel costs the mean pixel cost of OUT's serial renders
(RAYSCHED_MPI_SPIN_NS_PER_PX). Their walls are the MPI master's period per item with items of
a known cost, the refill period `raysched simulate` reads (validation.mpi_spin); their images
are black, so those launches report mismatches by design.

Needs a binary built with `cargo build --features mpi`. Every mpirun has a deadline; past it
its whole process group is killed. A transport this script cannot set up is skipped with a
message (launch it by hand with RAYSCHED_MPI_TRANSPORT=<name>)."""
import argparse, os, pathlib, signal, subprocess, sys, tomllib

ROOT = pathlib.Path(__file__).resolve().parent.parent
# RAYSCHED_BIN picks the binary (e.g. target/release/raysched built with --features mpi).
BIN = pathlib.Path(os.environ.get("RAYSCHED_BIN", ROOT / "target" / "debug" / "raysched"))
# No binding: OpenMPI binds each of 2 ranks to one core (rank 0 then sees 1 core, 3 ranks see
# 2), and a runs.csv refuses launches that saw different core counts.
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1", OMPI_MCA_mpi_yield_when_idle="1",
           OMPI_MCA_hwloc_base_binding_policy="none")
TRANSPORT_ENV = {
    "shared_memory": {"OMPI_MCA_btl": "self,vader"},
    "tcp_loopback": {"OMPI_MCA_btl": "self,tcp", "OMPI_MCA_btl_tcp_if_include": "lo"},
    "tcp_netem": {"OMPI_MCA_btl": "self,tcp", "OMPI_MCA_btl_tcp_if_include": "lo",
                  "RAYSCHED_MPI_TRANSPORT": "tcp_netem"},
}
DEADLINE_S = 900
# tcp_netem: every rank inside one scratch network namespace whose loopback delays each packet
# by this much (`tc netem`), a stand-in for a cluster link.
NETEM_NS = "raysched_netem"
NETEM_DELAY_MS = 0.5


def netem_setup():
    """(command prefix, None) when the delayed namespace is ready, else (None, the refusal)."""
    subprocess.run(["ip", "netns", "del", NETEM_NS], capture_output=True)
    r = subprocess.run(["ip", "netns", "add", NETEM_NS], capture_output=True, text=True)
    if r.returncode != 0:
        return None, "cannot create a network namespace: " + (r.stderr.strip() or "ip netns add failed")
    subprocess.run(["ip", "-n", NETEM_NS, "link", "set", "lo", "up"], capture_output=True)
    r = subprocess.run(["ip", "netns", "exec", NETEM_NS, "tc", "qdisc", "add", "dev", "lo", "root",
                        "netem", "delay", f"{NETEM_DELAY_MS}ms"], capture_output=True, text=True)
    if r.returncode != 0:
        netem_teardown()
        return None, "the kernel refuses netem: " + (r.stderr.strip() or "tc qdisc add failed")
    return ["ip", "netns", "exec", NETEM_NS], None


def netem_teardown():
    subprocess.run(["ip", "netns", "del", NETEM_NS], capture_output=True)


def spin_ns_per_px(out, experiment):
    """Median serial wall of OUT's runs.csv of EXPERIMENT over its pixels, in ns."""
    import csv, statistics
    rows = [r for r in csv.DictReader(open(out / pathlib.Path(experiment).stem / "runs.csv"))
            if r["scheduler"] == "serial" and r["sources"] == "local"]
    if not rows:
        sys.exit(f"--spin: no serial rows in {out / pathlib.Path(experiment).stem / 'runs.csv'}")
    px = int(rows[0]["width"]) * int(rows[0]["height"])
    return statistics.median(float(r["wall_s"]) for r in rows) / px * 1e9


def launch(ranks, transport, experiment, out, fresh, prefix=(), extra_env=None):
    cmd = [*prefix, "mpirun", "-n", str(ranks), str(BIN), "run", str(experiment), "--out", str(out), "--quiet"]
    if fresh:
        cmd.append("--fresh")
    env = dict(ENV, **TRANSPORT_ENV[transport], **(extra_env or {}))
    print(f"== {' '.join(cmd)}  ({transport}: {TRANSPORT_ENV[transport]} {extra_env or ''})", flush=True)
    p = subprocess.Popen(cmd, env=env, start_new_session=True)
    try:
        return p.wait(timeout=DEADLINE_S)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()
        print(f"   killed after {DEADLINE_S} s", flush=True)
        return 124


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("experiment", nargs="?", default=str(ROOT / "experiments" / "mpi.toml"))
    ap.add_argument("--fresh", action="store_true", help="start runs.csv over (first launch only)")
    ap.add_argument("--out", default=str(ROOT / "results" / "runs"))
    ap.add_argument("--spin", help="launch again into this folder with spinning workers")
    a = ap.parse_args()
    spec = tomllib.loads(pathlib.Path(a.experiment).read_text())
    mpi = spec["mpi"]
    ranks = mpi["ranks"] if isinstance(mpi["ranks"], list) else [mpi["ranks"]]
    out, spin = pathlib.Path(a.out), a.spin and pathlib.Path(a.spin)
    failed, fresh = 0, a.fresh
    for k in ranks:
        for t in mpi["transports"]:
            failed += sweep(a.experiment, out, fresh, [k], [t])
            if spin:
                # Right after its rendering launch, so both see the machine alike. Black
                # images differ from the serial's: these launches exit 1 by design.
                ns = spin_ns_per_px(out, a.experiment)
                print(f"== spinning workers: {ns:.1f} ns per pixel", flush=True)
                sweep(a.experiment, spin, fresh, [k], [t],
                      {"RAYSCHED_MPI_SPIN_NS_PER_PX": f"{ns:.3f}"})
            fresh = False
    sys.exit(1 if failed else 0)


def sweep(experiment, out, fresh, ranks, transports, extra_env=None):
    """One launch per (ranks, transport); how many failed."""
    failed = 0
    for k in ranks:
        for t in transports:
            if t not in TRANSPORT_ENV:
                print(f"{t}: skipped, this driver cannot set it up (launch by hand with RAYSCHED_MPI_TRANSPORT={t})")
                continue
            prefix = ()
            if t == "tcp_netem":
                prefix, refusal = netem_setup()
                if refusal:
                    print(f"{t}: skipped, {refusal}", flush=True)
                    continue
            try:
                rc = launch(k, t, experiment, out, fresh, prefix, extra_env)
            finally:
                if t == "tcp_netem":
                    netem_teardown()
            fresh = False
            if rc != 0:
                failed += 1
                print(f"   ranks={k} {t}: exit {rc}", flush=True)
    return failed


if __name__ == "__main__":
    main()
