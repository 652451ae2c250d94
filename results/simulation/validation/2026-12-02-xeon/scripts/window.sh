#!/bin/bash
# One validation window: measured threads, MPI (rendering, then spinning), simulation.
# $1: run name (A, B); $2: "nospin" to also simulate without the MPI spinning period.
set -u
cd "$(git rev-parse --show-toplevel)"
R=$1; BIN=target-rel/release/raysched; D=results/simulation/validation/2026-12-02-xeon/$R
mkdir -p $D
log(){ echo "$(date -u +%T) $* | $(uptime)" >> $D/window.txt; }
{ date -u; echo "commit $(git rev-parse --short HEAD), $(git status --porcelain | wc -l) dirty files; binary $(sha256sum $BIN | cut -c1-12) (release, features simgrid,mpi)"; lscpu | grep 'Model name'; nproc; } > $D/window.txt
log measured start
$BIN run experiments/simvalidate.toml --fresh --quiet > $D/measured_log.txt 2>&1; log measured end rc=$?
log mpi start
RAYSCHED_BIN=$BIN python3 experiments/mpi_sweep.py experiments/simvalidate_mpi.toml --fresh --spin results/runs_spin > $D/mpi_log.txt 2>&1; log mpi end rc=$?
log simulate start
$BIN simulate experiments/simulation_validation.toml > $D/simulate_log.txt 2>&1; log simulate end rc=$?
cp results/runs/simvalidate/runs.csv $D/measured_runs.csv; cp results/runs/simvalidate/meta.toml $D/measured_meta.toml
mkdir -p $D/mpi $D/mpi_spin $D/sim
cp results/runs/simvalidate_mpi/runs.csv results/runs/simvalidate_mpi/meta.toml $D/mpi/
cp results/runs_spin/simvalidate_mpi/runs.csv results/runs_spin/simvalidate_mpi/meta.toml $D/mpi_spin/
cp -r results/runs/simulation_validation/validation.csv results/runs/simulation_validation/report.md results/runs/simulation_validation/inputs.toml results/runs/simulation_validation/plots $D/sim/
if [ "${2:-}" = nospin ]; then
  grep -v '^mpi_spin' experiments/simulation_validation.toml | sed 's/^description = "/description = "Without the MPI spinning period: /' > experiments/simulation_validation_nospin.toml
  log simulate-nospin start
  $BIN simulate experiments/simulation_validation_nospin.toml > $D/simulate_nospin_log.txt 2>&1; log simulate-nospin end rc=$?
  mkdir -p $D/sim_nospin
  cp -r results/runs/simulation_validation_nospin/validation.csv results/runs/simulation_validation_nospin/report.md results/runs/simulation_validation_nospin/plots $D/sim_nospin/
  rm experiments/simulation_validation_nospin.toml
fi
log done
