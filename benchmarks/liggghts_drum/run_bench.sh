#!/bin/bash
# LIGGGHTS throughput on the drum of benchmarks/yade_drum_throughput.py (same lattice, radii, Δt).
# Usage: run_bench.sh RD L SETTLE MEASURE NPROCS   (needs: apt-get install -y liggghts)
set -eu
here=$(cd "$(dirname "$0")" && pwd); t=$(mktemp -d); trap 'rm -rf "$t"' EXIT
cd "$t"; cp "$here/in.drum" .; python3 "$here/make_drum.py" "$1" "$2" > /dev/null
n=$(awk '/ atoms$/ {print $1}' drum.data)
mpirun --allow-run-as-root --oversubscribe -np "$5" liggghts -echo none -in in.drum -var settle "$3" -var measure "$4" > out.txt 2>&1
wall=$(grep "Loop time" out.txt | sed -n 3p | awk '{print $4}')
pairs=$(awk 'NR==4 {print $1; exit}' pairs.end)
python3 -c "print(f'RESULT liggghts particles=$n procs=$5 measure_steps=$4 wall_s=$wall particle_steps_per_s={$n*$4/$wall:.3e} pair_interactions_per_particle={2*$pairs/$n:.2f}')"
