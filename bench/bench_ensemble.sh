#!/usr/bin/env bash
# Ensemble benchmark (issue 4): replicates per second at P = 1 and P = 2 on
# the default scenario, the speed-up, and the ensemble's overhead (MPI, HDF5,
# start-up, closing write) as a fraction of the replicates' own run time.
# Then the coordinator's ceiling: rows per second rank 0 takes in, hands out
# and writes when replicates are nearly free (for the 1000-rank projection).
#
# usage: bench/bench_ensemble.sh RINGSIM [REPEATS=3] [R=16] [T_MAX=200]
# P = 1 and P = 2 runs alternate, so both see the same machine load; the
# figures are medians over REPEATS, and the speed-up is also given per pair.
set -euo pipefail
RINGSIM=${1:?usage: bench_ensemble.sh RINGSIM [REPEATS] [R] [T_MAX]}
REPEATS=${2:-3}
R=${3:-16}
TMAX=${4:-200}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

run() {  # run P FILE EXTRA...: prints the wall seconds of the whole command
  local p=$1 f=$2
  shift 2
  local t0 t1
  t0=$(date +%s.%N)
  mpirun --oversubscribe -np "$p" "$RINGSIM" run --replicates "$R" --seed 11 -o "$f" --force "$@" \
    > /dev/null 2> "$f.log"
  t1=$(date +%s.%N)
  echo "$t0 $t1" | awk '{printf "%.3f", $2 - $1}'
}

sum_wall() {  # total of the replicates' own wall_seconds in FILE
  /usr/bin/python3 -c 'import h5py,sys; print("%.3f" % h5py.File(sys.argv[1])["replicates"]["wall_seconds"].sum())' "$1"
}

echo "default scenario, t_max = $TMAX, R = $R replicates, $REPEATS repeats (P = 1 and 2 alternating)"
echo "repeat  P=1 wall(s)  P=1 rep/s  overhead(P=1)  P=2 wall(s)  P=2 rep/s  speed-up  replicate slow-down(P=2)  busy(P=2)"
: > "$tmp/rows"
for k in $(seq 1 "$REPEATS"); do
  w1=$(run 1 "$tmp/p1.h5" --set run.t_max="$TMAX")
  s1=$(sum_wall "$tmp/p1.h5")
  w2=$(run 2 "$tmp/p2.h5" --set run.t_max="$TMAX")
  s2=$(sum_wall "$tmp/p2.h5")
  # overhead(P=1): time outside replicates / time inside them (start-up,
  # hand-out, HDF5, closing write); slow-down: the same replicates' own run
  # time with both cores busy / alone; busy(P=2): fraction of 2 x wall spent
  # inside replicates (the rest: start-up, hand-out, last-replicate imbalance).
  echo "$k $w1 $s1 $w2 $s2" | awk -v R="$R" '{
    r1 = R / $2; r2 = R / $4;
    printf "%6d  %11.2f  %9.3f  %12.2f%%  %11.2f  %9.3f  %8.3f  %24.3f  %8.1f%%\n",
           $1, $2, r1, 100 * ($2 - $3) / $3, $4, r2, r2 / r1, $5 / $3, 100 * $5 / (2 * $4) }' \
    | tee -a "$tmp/rows"
done
median() { sort -g -k"$1" "$tmp/rows" | awk -v c="$1" '{a[NR] = $c} END {print a[int((NR + 1) / 2)]}'; }
echo "medians: speed-up P=2/P=1 $(median 7); overhead at P=1 $(median 4); replicate slow-down at P=2 $(median 8); busy at P=2 $(median 9)"

# Coordinator ceiling: 4 bodies, t_max = 0.01, so a replicate costs ~0.1 ms
# and rank 0's hand-out + HDF5 writes are the bottleneck.
N=20000
t=$(R=$N run 4 "$tmp/tiny.h5" --set init.spheres=2 --set init.linkers=2 --set geometry.box_length=20 \
      --set run.t_max=0.01 --set run.steady_state=false)
echo "$t" | awk -v n="$N" '{printf "coordinator ceiling: %d tiny replicates on 4 ranks in %.2f s = %.0f rows/s\n", n, $1, n / $1}'
