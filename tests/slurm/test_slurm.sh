#!/usr/bin/env bash
# End-to-end test of jobs/slurm on a real Slurm: starts a private single-node
# cluster on this machine (its own munged, slurmctld and slurmd, config, ports
# and state under one temporary directory; nothing in /etc is changed), then
#
#   1. submits the study script for two scenarios with small settings (a
#      job array, srun --mpi=pmix), stops task 0 mid-run with SIGUSR1 the way
#      Slurm does before a time limit (`scancel --batch --signal=USR1`), and
#      checks that the task saved its replicates, requeued itself and resumed,
#      that the aggregation job waited for it, and the .h5 files and Table 5
#      (one row per scenario, every replicate done);
#   2. the same stop and requeue for a single scenario job with mpirun as the
#      launcher, and both requeued results against an uninterrupted run
#      (identical Table 5 row);
#   3. with --time-limit only (about 3 minutes more): a job with a 1-minute
#      limit and `--signal=B:USR1@30` that needs several runs, requeueing
#      itself before each limit until the file is complete.
#
# Needs root (installs slurmctld, slurmd, slurm-client, munge and hdf5-tools
# with apt-get when missing and runs the daemons); prints SKIP and exits 77
# otherwise. Stops every daemon it started on exit; prints PASS or FAIL last.
# Takes about a minute here (2 cores).
#
#   bash tests/slurm/test_slurm.sh [--ringsim PATH] [--keep] [--timeout SECS]
#                                  [--no-install] [--time-limit]
#
# --ringsim: the executable (default: $RINGSIM, else build/ringsim); --keep:
# keep the work directory (logs, results) after a pass; --timeout: seconds to
# wait for a job (default 300); --no-install: fail instead of apt-get.
set -uo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
ringsim=${RINGSIM:-$repo/build/ringsim}
keep=0
timeout=300
time_limit_case=0
install=1
port=${RINGSIM_TEST_SLURM_PORT:-16817}  # slurmctld; slurmd uses port + 1

while [ $# -gt 0 ]; do
  case "$1" in
    --ringsim) ringsim=$2; shift 2 ;;
    --keep) keep=1; shift ;;
    --timeout) timeout=$2; shift 2 ;;
    --no-install) install=0; shift ;;
    --time-limit) time_limit_case=1; shift ;;
    -h|--help) awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "${BASH_SOURCE[0]}"; exit 0 ;;
    *) echo "unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
done

t_start=$SECONDS
note() { printf '[test_slurm %4ds] %s\n' $((SECONDS - t_start)) "$*"; }
failures=0
check() {  # check DESCRIPTION COMMAND...: one PASS/FAIL line
  local what=$1; shift
  if "$@"; then echo "  ok    $what"; else echo "  FAIL  $what"; failures=$((failures + 1)); fi
}
abort() { echo "FAIL: $*"; failures=$((failures + 1)); exit 1; }

[ "$(id -u)" = 0 ] || { echo "SKIP: needs root (apt-get, and slurmd runs jobs as their user)"; exit 77; }
[ -x "$ringsim" ] || abort "no ringsim executable at $ringsim (build it, or pass --ringsim PATH)"
ringsim=$(cd "$(dirname "$ringsim")" && pwd)/$(basename "$ringsim")

# --- packages -----------------------------------------------------------------
declare -A package_of=([slurmctld]=slurmctld [slurmd]=slurmd [sbatch]=slurm-client
                       [munged]=munge [h5dump]=hdf5-tools [mpirun]=openmpi-bin)
missing=()
for cmd in "${!package_of[@]}"; do
  command -v "$cmd" > /dev/null || missing+=("${package_of[$cmd]}")
done
if [ ${#missing[@]} -gt 0 ]; then
  [ "$install" = 1 ] || abort "missing packages: ${missing[*]} (run without --no-install)"
  note "installing ${missing[*]}"
  { apt-get update -q && DEBIAN_FRONTEND=noninteractive \
      apt-get install -y -q --no-install-recommends "${missing[@]}"; } > /tmp/test_slurm_apt.log 2>&1 ||
    abort "apt-get install ${missing[*]} failed, see /tmp/test_slurm_apt.log"
fi

# --- a private single-node cluster ----------------------------------------------
work=$(mktemp -d /tmp/ringsim-slurm-test.XXXXXX)
chmod 711 "$work"  # munged wants its socket directory searchable by all
mkdir -p "$work/munge" "$work/ctld" "$work/spool" "$work/log"
chmod 711 "$work/munge"

cleanup() {
  local rc=$?
  trap - EXIT INT TERM
  if [ -f "$work/slurm.conf" ]; then
    local jobs
    read -r -a jobs <<< "$(squeue -h -o %A 2> /dev/null | sort -u | tr '\n' ' ')"
    [ ${#jobs[@]} -eq 0 ] || scancel "${jobs[@]}" 2> /dev/null
  fi
  for pidfile in "$work/slurmd.pid" "$work/slurmctld.pid" "$work/munge/munged.pid"; do
    [ -f "$pidfile" ] || continue
    local pid
    pid=$(cat "$pidfile")
    kill "$pid" 2> /dev/null || continue
    for _ in $(seq 50); do kill -0 "$pid" 2> /dev/null || break; sleep 0.2; done
    kill -0 "$pid" 2> /dev/null && kill -9 "$pid" 2> /dev/null
  done
  if [ "$failures" -gt 0 ] || [ "$rc" -ne 0 ]; then
    echo "--- logs kept in $work (slurm daemons: $work/log, jobs: */logs, requeue/job.log)"
    tail -n 5 "$work"/log/*.log 2> /dev/null | sed 's/^/    /'
    echo "FAIL: tests/slurm/test_slurm.sh ($failures failed) after $((SECONDS - t_start)) s"
    exit 1
  fi
  if [ "$keep" = 1 ]; then echo "kept $work"; else rm -rf "$work"; fi
  echo "PASS: tests/slurm/test_slurm.sh in $((SECONDS - t_start)) s"
  exit 0
}
trap cleanup EXIT
trap 'exit 1' INT TERM

head -c 1024 /dev/urandom > "$work/munge/munge.key"
chmod 400 "$work/munge/munge.key"
/usr/sbin/munged --key-file="$work/munge/munge.key" --socket="$work/munge/munge.sock" \
    --pid-file="$work/munge/munged.pid" --log-file="$work/munge/munged.log" \
    --seed-file="$work/munge/munged.seed" || abort "munged did not start (see $work/munge/munged.log)"

# Two free ports for slurmctld and slurmd (a real Slurm here keeps 6817/6818).
listening() { (exec 3<> "/dev/tcp/127.0.0.1/$1") 2> /dev/null; }
for _ in $(seq 20); do
  listening "$port" || listening $((port + 1)) || break
  port=$((port + 2))
done
host=$(hostname -s)
# The node as slurmd sees it (CPUs, sockets, cores, memory), so it is not
# drained for claiming more than it has.
node=$(slurmd -C | head -n 1)
[[ $node == NodeName=* ]] || abort "slurmd -C printed no node line: $node"
cat > "$work/slurm.conf" <<EOF
# Single-node test cluster written by tests/slurm/test_slurm.sh.
ClusterName=ringsim-test
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
# cred_expire also delays the restart of a requeued job (default 120 s)
AuthInfo=socket=$work/munge/munge.sock,cred_expire=10
StateSaveLocation=$work/ctld
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
# a container: no cgroups, no accounting
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
SchedulerParameters=bf_interval=1,sched_interval=2
MpiDefault=none
ReturnToService=2
MinJobAge=3600
KillWait=10
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
sed -i 's/ UpTime=[^ ]*//' "$work/slurm.conf"

# Everything below talks to this cluster only; nothing of an outer Slurm job
# (if this runs inside one) may leak into the submissions.
for v in $(compgen -e); do
  case "$v" in SLURM_*|SBATCH_*|SALLOC_*|SRUN_*) unset "$v" ;; esac
done
export SLURM_CONF=$work/slurm.conf
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1  # the jobs run as root here

slurmctld || abort "slurmctld did not start (see $work/log/slurmctld.log)"
slurmd || abort "slurmd did not start (see $work/log/slurmd.log)"
for _ in $(seq 60); do
  [ "$(sinfo -h -n "$host" -o %t 2> /dev/null)" = idle ] && break
  sleep 1
done
[ "$(sinfo -h -n "$host" -o %t 2> /dev/null)" = idle ] ||
  abort "node $host not idle after 60 s: $(sinfo -h -N -o '%N %t %E' 2>&1)"
note "cluster up: $(sinfo -h -N -o '%N %c CPUs %m MB %t') (Slurm $(sinfo -V | cut -d' ' -f2))"

# --- helpers -------------------------------------------------------------------
field() { scontrol show job -o "$1" 2> /dev/null | grep -o "$2=[^ ]*" | head -n 1 | cut -d= -f2; }
wait_for_state() {  # wait_for_state JOB 'REGEX' [SECONDS]: until every record of JOB matches
  local job=$1 re=$2 limit=${3:-$timeout} end=$((SECONDS + ${3:-$timeout})) states
  while [ $SECONDS -lt $end ]; do
    states=$(scontrol show job -o "$job" 2> /dev/null | grep -o 'JobState=[A-Z_]*' | cut -d= -f2 | sort -u)
    if [ -n "$states" ] && ! grep -qvE "^($re)$" <<< "$states"; then return 0; fi
    sleep 1
  done
  echo "  job $job still $(tr '\n' ' ' <<< "$states")after $limit s" >&2
  return 1
}
attr_complete() {  # the root attribute `complete` of a result file
  h5dump -a /complete "$1" 2> /dev/null | sed -n 's/^ *(0): *//p'
}
csv_column() {  # csv_column FILE COLUMN: that column of every data row (quoted fields may hold commas)
  /usr/bin/python3 -c 'import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
for r in rows:
    if sys.argv[2] in r: print(r[sys.argv[2]])' "$1" "$2"
}
all_equal() {  # all_equal VALUE LINES: every line equals VALUE (and there is one)
  [ -n "$2" ] && ! grep -qvx -- "$1" <<< "$2"
}
all_done() {  # all_done CSV R: every row of a Table 5 CSV has n_ok = R and n_pending = 0
  all_equal "$2" "$(csv_column "$1" n_ok)" && all_equal 0 "$(csv_column "$1" n_pending)"
}

done_rows() {  # replicates finished so far in a result file (readable while written)
  HDF5_USE_FILE_LOCKING=FALSE "$ringsim" aggregate "$1" --format csv 2> /dev/null | csv_column /dev/stdin n_ok
}
stop_mid_run() {  # stop_mid_run JOB FILE LOG: SIGUSR1 to the batch shell once a few replicates are in
  # `scancel --batch --signal=USR1` reaches the batch shell exactly as
  # `#SBATCH --signal=B:USR1@SECS` does before the time limit.
  local n=0
  for _ in $(seq 240); do
    n=$(done_rows "$2")
    [ "${n:-0}" -ge 1 ] && break
    sleep 0.5
  done
  scancel --batch --signal=USR1 "$1"
  note "   SIGUSR1 sent to the batch shell of $1 (${n:-0} of $R replicates in the file)"
  for _ in $(seq 60); do grep -q 'requeueing' "$3" 2> /dev/null && break; sleep 0.5; done
  check "$1: the batch shell forwarded SIGUSR1, the ranks saved, the job requeued itself" \
    grep -q 'requeueing job' "$3"
  check "$1: the file was left incomplete (complete = 0)" test "$(attr_complete "$2")" = 0
}
resumed_ok() {  # resumed_ok JOB LOG: after the requeue the job started again and completed
  local state restarts starts
  state=$(field "$1" JobState)
  restarts=$(field "$1" Restarts)
  starts=$(grep -c 'start [0-9]*,' "$2")
  check "$1: COMPLETED after one requeue and a resumed second start ($state, Restarts=$restarts, $starts starts)" \
    test "$state/$restarts/$starts" = COMPLETED/1/2
}

# One configuration, ~40-100 s on 2 ranks here (by load): the stop comes
# mid-run, and an uninterrupted run of it is the reference at the end. (With
# t_max = 50, and again with 300 on an idle machine, the job finished all or
# nearly all of its 60 replicates before the first poll saw a row (58 of 60
# at 300), so the stop came too late.)
# (Scenario first: `ringsim run`'s --set takes every following word as a value.)
R=60
seed=11
# The job machinery, not the physics: the welded reading keeps replicates short.
sets=(--set run.t_max=900 --set bonding.joint=welded)
scenarios=(1-baseline 4-passive-selection)

# --- 1. the study: job array + dependent aggregation, one task requeued ---------
note "1. study: ${scenarios[*]} as one job array, then the aggregation job"
study=$work/study
paths=()
for n in "${scenarios[@]}"; do paths+=("$repo/jobs/scenarios/$n.toml"); done
ids=$("$repo/jobs/slurm/submit-study.sh" --parsable -R $R -s $seed -n 2 -t 10 -o "$study" \
        "${sets[@]}" --ringsim "$ringsim" "${paths[@]}") ||
  abort "submit-study.sh failed: $ids"
read -r array_id aggregate_id <<< "$ids"
[[ $array_id =~ ^[0-9]+$ && $aggregate_id =~ ^[0-9]+$ ]] || abort "submit-study.sh --parsable printed '$ids'"
note "   job array $array_id, aggregation job $aggregate_id"
check "the aggregation job depends on the array (afterany)" \
  grep -q "afterany:${array_id}" <<< "$(field "$aggregate_id" Dependency)"
wait_for_state "${array_id}_0" RUNNING 60 || abort "array task ${array_id}_0 did not start"
stop_mid_run "${array_id}_0" "$study/1-baseline.h5" "$study/logs/ringsim-${array_id}_0.log"
check "the aggregation job waits for the requeued task" \
  test "$(field "$aggregate_id" JobState)" = PENDING
wait_for_state "$aggregate_id" 'COMPLETED|FAILED|CANCELLED|TIMEOUT|NODE_FAIL|OUT_OF_MEMORY'
note "   aggregation job ended"
resumed_ok "${array_id}_0" "$study/logs/ringsim-${array_id}_0.log"
check "every array task COMPLETED" wait_for_state "$array_id" COMPLETED 5
check "the aggregation job COMPLETED" wait_for_state "$aggregate_id" COMPLETED 5
for n in "${scenarios[@]}"; do
  check "$n.h5 is a complete result file" test "$(attr_complete "$study/$n.h5")" = 1
  check "table5.md has one row for $n" test "$(grep -c "^| $n |" "$study/table5.md" 2> /dev/null)" = 1
done
check "table5.md has ${#scenarios[@]} rows" \
  test "$(grep -c '^| ' "$study/table5.md" 2> /dev/null)" = $((${#scenarios[@]} + 1))
check "table5.csv has ${#scenarios[@]} rows" \
  test "$(tail -n +2 "$study/table5.csv" 2> /dev/null | wc -l)" = ${#scenarios[@]}
check "table5.csv: n_ok = $R, n_pending = 0 in every row (aggregated after the requeued task)" \
  all_done "$study/table5.csv" $R
check "the tasks started their ranks with srun --mpi=pmix (launcher auto)" \
  grep -q 'srun --mpi=pmix' "$study/logs/ringsim-${array_id}_0.log"

# --- 2. one scenario job with mpirun as the launcher, requeued -----------------------
note "2. requeue: one scenario job, mpirun as the launcher"
rq=$work/requeue
mkdir -p "$rq"
job=$(cd "$rq" && sbatch --parsable --ntasks=2 --time=10 --output="$rq/job.log" \
        "$repo/jobs/slurm/ringsim-scenario.sbatch" --ringsim "$ringsim" --launcher mpirun \
        -o "$rq/1-baseline.h5" --replicates $R --seed $seed "${sets[@]}" \
        "$repo/jobs/scenarios/1-baseline.toml") || abort "sbatch failed: $job"
note "   job $job"
wait_for_state "$job" RUNNING 60 || abort "job $job did not start"
stop_mid_run "$job" "$rq/1-baseline.h5" "$rq/job.log"
wait_for_state "$job" COMPLETED || true
note "   job ended"
resumed_ok "$job" "$rq/job.log"
check "the file is complete" test "$(attr_complete "$rq/1-baseline.h5")" = 1

# --- the requeued results equal an uninterrupted run's ---------------------------
note "   uninterrupted reference run (mpirun -np 2)"
mpirun -np 2 "$ringsim" run "$repo/jobs/scenarios/1-baseline.toml" --replicates $R --seed $seed \
  "${sets[@]}" -o "$work/reference.h5" > "$work/reference.log" 2>&1
row() { "$ringsim" aggregate "$1" --format csv 2> /dev/null | grep '^1-baseline,'; }
reference=$(row "$work/reference.h5")
check "the reference run has its row" test -n "$reference"
check "requeued array task (srun): Table 5 row equals the uninterrupted run's" \
  test "$(grep '^1-baseline,' "$study/table5.csv")" = "$reference"
check "requeued job (mpirun): Table 5 row equals the uninterrupted run's" \
  test "$(row "$rq/1-baseline.h5")" = "$reference"

# --- 3. (--time-limit) the real time limit, several requeues ------------------------
if [ "$time_limit_case" = 1 ]; then
  note "3. time limit: 1 minute, --signal=B:USR1@30, 400 replicates (about 100 s of work)"
  tl=$work/time-limit
  mkdir -p "$tl"
  job=$(cd "$tl" && sbatch --parsable --ntasks=2 --time=1 --signal=B:USR1@30 --output="$tl/job.log" \
          "$repo/jobs/slurm/ringsim-scenario.sbatch" --ringsim "$ringsim" -o "$tl/1-baseline.h5" \
          --replicates 400 --seed $seed "${sets[@]}" "$repo/jobs/scenarios/1-baseline.toml") ||
    abort "sbatch failed: $job"
  wait_for_state "$job" COMPLETED 900 || true
  state=$(field "$job" JobState)
  restarts=$(field "$job" Restarts)
  note "   job ended: $state after $restarts requeues"
  check "COMPLETED after requeues before the time limit" test "$state" = COMPLETED -a "${restarts:-0}" -ge 1
  check "SIGUSR1 came before the limit each time (no TIMEOUT)" \
    test "$(grep -c 'DUE TO TIME LIMIT' "$tl/job.log")" = 0
  check "the file is complete" test "$(attr_complete "$tl/1-baseline.h5")" = 1
fi
