#!/usr/bin/env python3
"""Drive the MPI experiment: one `mpirun -n K raysched run EXPERIMENT` per (ranks, transport)
of its [mpi] table; each launch appends its rows to OUT/<name>/runs.csv (the serial and
local-thread baselines are measured by the first launch that needs them) and redraws the plots
and report.md.

    python3 experiments/mpi_sweep.py [experiments/mpi.toml] [--fresh] [--out results/runs]

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


def launch(ranks, transport, experiment, out, fresh, prefix=()):
    cmd = [*prefix, "mpirun", "-n", str(ranks), str(BIN), "run", str(experiment), "--out", str(out), "--quiet"]
    if fresh:
        cmd.append("--fresh")
    env = dict(ENV, **TRANSPORT_ENV[transport])
    print(f"== {' '.join(cmd)}  ({transport}: {TRANSPORT_ENV[transport]})", flush=True)
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
    a = ap.parse_args()
    spec = tomllib.loads(pathlib.Path(a.experiment).read_text())
    mpi = spec["mpi"]
    ranks = mpi["ranks"] if isinstance(mpi["ranks"], list) else [mpi["ranks"]]
    fresh, failed = a.fresh, 0
    for k in ranks:
        for t in mpi["transports"]:
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
                rc = launch(k, t, a.experiment, a.out, fresh, prefix)
            finally:
                if t == "tcp_netem":
                    netem_teardown()
            fresh = False
            if rc != 0:
                failed += 1
                print(f"   ranks={k} {t}: exit {rc}", flush=True)
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
