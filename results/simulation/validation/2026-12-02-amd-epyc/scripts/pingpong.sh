#!/bin/bash
# Ping-pong, both transports, 3 launches each interleaved, the MPI sweep's settings
# (mpicc -O2 -o /tmp/sim_pingpong experiments/mpi_pingpong.c; run under /work/notes/quiet).
out=results/simulation/validation/2026-12-02-amd-epyc
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1 OMPI_MCA_mpi_yield_when_idle=1 OMPI_MCA_hwloc_base_binding_policy=none
{ date -u; uptime; lscpu | grep 'Model name'; } > $out/pingpong_log.txt
for k in 1 2 3; do
  echo "== shared_memory $k $(date -u +%T)" >> $out/pingpong_log.txt
  OMPI_MCA_btl=self,vader mpirun -n 2 /tmp/sim_pingpong >> $out/pingpong_log.txt 2>&1
  echo "== tcp_loopback $k $(date -u +%T)" >> $out/pingpong_log.txt
  OMPI_MCA_btl=self,tcp OMPI_MCA_btl_tcp_if_include=lo mpirun -n 2 /tmp/sim_pingpong >> $out/pingpong_log.txt 2>&1
done
uptime >> $out/pingpong_log.txt
