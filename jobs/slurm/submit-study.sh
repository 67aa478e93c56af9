#!/usr/bin/env bash
# Submit the whole study to Slurm: one job array with one task per scenario
# (jobs/slurm/ringsim-scenario.sbatch, each task writing OUTDIR/<scenario>.h5)
# and an aggregation job that starts when every task has ended and writes
# Table 5 as OUTDIR/table5.md and OUTDIR/table5.csv. Run with --help.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
template=$here/ringsim-scenario.sbatch
# die, need_value, is_count, the shared options, scenarios and executable
# shellcheck source=jobs/lib/common.sh
. "$repo/jobs/lib/common.sh" || { echo "submit-study.sh: cannot read $repo/jobs/lib/common.sh" >&2; exit 1; }

usage() {
  cat <<EOF
submit-study.sh: submit the ringsim study to Slurm as one job array plus one
aggregation job.

  jobs/slurm/submit-study.sh [OPTIONS] [SCENARIO.toml...]

Without scenarios, every file in jobs/scenarios/ is one task of the array.
Each task runs \`ringsim run SCENARIO --replicates R --seed S
-o OUTDIR/<scenario>.h5 --resume\` over its ranks; the aggregation job then
runs \`ringsim aggregate\` on those files and writes OUTDIR/table5.md and
OUTDIR/table5.csv. It starts when every task has ended, however it ended
(afterany), so a failed scenario still leaves a table of the others.

Options:
  -R, --replicates R    replicates per scenario (default 1000, the study's)
  -s, --seed S          base seed, the same for every scenario (default 1)
  -n, --ranks P         MPI ranks per scenario, i.e. Slurm tasks (default 4)
  -t, --time T          time limit per scenario task, Slurm format
                        (minutes, H:MM:SS or D-HH; default 24:00:00)
  -p, --partition P     partition for every job (default: the cluster's)
  -A, --account A       account to charge
  -o, --outdir DIR      results directory (default results); logs go to
                        DIR/logs, the task -> scenario list to DIR/scenarios.txt
      --set KEY=VALUE   configuration override for every scenario (repeatable)
      --ringsim PATH    the executable (default: $repo/build/ringsim
                        when it exists, else \`ringsim\` on PATH)
      --launcher L      auto | srun | mpirun (default auto: \`srun --mpi=pmix\`
                        when Slurm has the pmix plugin, else mpirun)
      --max-parallel N  run at most N scenarios at a time (--array=...%N)
      --stop-before SEC signal the ranks SEC seconds before the time limit so
                        they save their results and the task requeues itself
                        to continue (default 120)
      --sbatch OPTION   extra sbatch option for every job (repeatable), e.g.
                        --sbatch=--mem-per-cpu=2G --sbatch=--qos=long
      --dry-run         print the sbatch commands instead of running them
      --parsable        print only "ARRAY_JOB_ID AGGREGATION_JOB_ID"
  -h, --help            this text

Time limits: a task that reaches its limit is not lost. --stop-before seconds
earlier the ranks stop, every finished replicate is already in the file, and
the task requeues itself; when it runs again it resumes. Pick --time so that
a few replicates at least fit into one run. Submitting the same command again
(say after changing nothing but --time) also resumes: finished scenarios
return at once, others continue. A different R, seed, --set or scenario file
is refused for an existing file; use a new --outdir.

Examples:
  # the study, 1000 replicates of every scenario, 8 ranks each
  jobs/slurm/submit-study.sh --ranks 8 --time 12:00:00 --partition compute
  # two scenarios, a quick look
  jobs/slurm/submit-study.sh -R 20 -n 2 -t 30 -o quick --set run.t_max=500 \\
      jobs/scenarios/1-baseline.toml jobs/scenarios/4-passive-selection.toml
  # watch, then read the table
  squeue --me;  cat results/table5.md
EOF
}

study_defaults  # -R 1000, -s 1, -o results, no --set, no scenarios
ranks=4
time_limit=24:00:00
partition=
account=
launcher=auto
max_parallel=
stop_before=120
parsable=0
extra=()

while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    -t|--time) need_value "$@"; time_limit=$2; shift 2 ;;
    -p|--partition) need_value "$@"; partition=$2; shift 2 ;;
    -A|--account) need_value "$@"; account=$2; shift 2 ;;
    --launcher) need_value "$@"; launcher=$2; shift 2 ;;
    --max-parallel) need_value "$@"; max_parallel=$2; shift 2 ;;
    --stop-before) need_value "$@"; stop_before=$2; shift 2 ;;
    --sbatch) need_value "$@"; extra+=("$2"); shift 2 ;;
    --sbatch=*) extra+=("${1#--sbatch=}"); shift ;;
    --parsable) parsable=1; shift ;;
    *) take_study_option "$@"; shift "$nargs" ;;  # -R -s -n -o --set --ringsim --dry-run, scenarios
  esac
done

check_study_values
is_count "$stop_before" || die "--stop-before must be a positive number of seconds, not '$stop_before'"
[ -z "$max_parallel" ] || is_count "$max_parallel" || die "--max-parallel must be a positive integer"
case "$launcher" in auto|srun|mpirun) ;; *) die "--launcher must be auto, srun or mpirun" ;; esac
check_sets

resolve_scenarios --absolute  # absolute paths, unique names
n_tasks=${#scenarios[@]}
resolve_ringsim

case "$outdir" in /*) ;; *) outdir=$PWD/$outdir ;; esac

common=()
[ -n "$partition" ] && common+=(--partition "$partition")
[ -n "$account" ] && common+=(--account "$account")
common+=("${extra[@]}")

# --- the job array ------------------------------------------------------------
array_cmd=(sbatch --parsable
  --job-name=ringsim-study
  --array="0-$((n_tasks - 1))${max_parallel:+%$max_parallel}"
  --ntasks="$ranks" --time="$time_limit"
  --requeue --signal="B:USR1@$stop_before" --open-mode=append
  --output="$outdir/logs/ringsim-%A_%a.log"
  "${common[@]}"
  "$template"
  --replicates "$replicates" --seed "$seed" --outdir "$outdir"
  --ringsim "$ringsim" --launcher "$launcher")
for s in "${sets[@]}"; do array_cmd+=(--set "$s"); done
array_cmd+=(-- "${scenarios[@]}")

# --- the aggregation job ------------------------------------------------------
# jobs/aggregate-study.sh takes exactly this study's files (not OUTDIR/*.h5,
# which could hold older results) and lists the missing ones.
wrap="exec bash $(printf '%q ' "$repo/jobs/aggregate-study.sh" --ringsim "$ringsim" "$outdir" "${names[@]}")"
aggregate_cmd=(sbatch --parsable
  --job-name=ringsim-aggregate
  --ntasks=1 --time=00:30:00
  --output="$outdir/logs/aggregate-%j.log"
  "${common[@]}"
  --wrap="$wrap")

if [ "$dry_run" = 1 ]; then
  [ "$parsable" = 1 ] || echo "# $n_tasks scenario tasks, then the aggregation job (dry run: nothing submitted)"
  printf '%q ' "${array_cmd[@]}"; echo
  printf '%q ' "${aggregate_cmd[@]:0:2}" --dependency=afterany:ARRAY_JOB_ID "${aggregate_cmd[@]:2}"; echo
  exit 0
fi

mkdir -p "$outdir/logs" || die "cannot create $outdir/logs"
printf '%s\n' "${scenarios[@]}" > "$outdir/scenarios.txt"
array_id=$("${array_cmd[@]}") || die "sbatch of the job array failed"
array_id=${array_id%%;*}  # --parsable prints "id" or "id;cluster"
if ! aggregate_id=$("${aggregate_cmd[@]:0:2}" --dependency="afterany:$array_id" "${aggregate_cmd[@]:2}"); then
  die "sbatch of the aggregation job failed; the scenarios run anyway (job array $array_id); aggregate by hand later: $wrap"
fi
aggregate_id=${aggregate_id%%;*}

if [ "$parsable" = 1 ]; then
  echo "$array_id $aggregate_id"
  exit 0
fi
echo "ringsim study: $n_tasks scenarios, R=$replicates, seed $seed, $ranks ranks each, time limit $time_limit"
for i in "${!scenarios[@]}"; do
  echo "  task $i: ${scenarios[$i]} -> $outdir/${names[$i]}.h5  (log: $outdir/logs/ringsim-${array_id}_$i.log)"
done
echo "job array $array_id; aggregation job $aggregate_id (after every task): $outdir/table5.md, $outdir/table5.csv"
echo "watch: squeue -j $array_id,$aggregate_id    stop and requeue a task: scancel --batch --signal=USR1 ${array_id}_TASK"
