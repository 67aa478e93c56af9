#!/usr/bin/env bash
# Submit the whole study to PBS Professional / OpenPBS: one job array with one
# subjob per scenario (jobs/pbs/ringsim-scenario.pbs, each writing
# OUTDIR/<scenario>.h5) and an aggregation job that starts when every subjob
# has ended and writes OUTDIR/table5.md and OUTDIR/table5.csv. Run with --help.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
template=$here/ringsim-scenario.pbs
# die, need_value, is_count, the shared options, scenarios and executable
# shellcheck source=jobs/lib/common.sh
. "$repo/jobs/lib/common.sh" || { echo "submit-study.sh: cannot read $repo/jobs/lib/common.sh" >&2; exit 1; }

usage() {
  cat <<EOF
submit-study.sh (PBS): submit the ringsim study as one job array plus one
aggregation job.

  jobs/pbs/submit-study.sh [OPTIONS] [SCENARIO.toml...]

Without scenarios, every file in jobs/scenarios/ is one subjob (qsub -J).
Each subjob runs \`mpirun --hostfile \$PBS_NODEFILE ringsim run SCENARIO
--replicates R --seed S -o OUTDIR/<scenario>.h5 --resume\`; the aggregation
job (-W depend=afterany:ARRAY) then writes OUTDIR/table5.md and table5.csv.
The study's parameters reach the subjobs through OUTDIR/study.txt.

Options:
  -R, --replicates R    replicates per scenario (default 1000, the study's)
  -s, --seed S          base seed, the same for every scenario (default 1)
  -n, --ranks P         MPI ranks per scenario on one node (default 4):
                        -l select=1:ncpus=P:mpiprocs=P
      --select SPEC     the whole select statement instead, e.g. 2:ncpus=32:mpiprocs=32
                        (ranks over several nodes need passwordless ssh: Debian's
                        Open MPI has no PBS tm support)
  -t, --time HH:MM:SS   walltime per scenario (default 24:00:00)
  -q, --queue Q         queue (default: the server's)
  -A, --account A       account to charge
  -o, --outdir DIR      results directory (default results); logs in DIR/logs
      --set KEY=VALUE   configuration override for every scenario (repeatable)
      --ringsim PATH    the executable (default: $repo/build/ringsim
                        when it exists, else \`ringsim\` on PATH)
      --stop-before SEC ask the ranks to stop cleanly SEC seconds before the
                        walltime (default 120)
      --qsub OPTION     extra qsub option for every job (repeatable), e.g.
                        --qsub=-P --qsub=myproject
      --dry-run         print the study file and the qsub commands only
      --parsable        print only "ARRAY_JOB_ID AGGREGATION_JOB_ID"
  -h, --help            this text

PBS sends no warning before the walltime; a watchdog in the job stops the
ranks --stop-before seconds early, with every finished replicate saved (exit
75). Submitting the same command again resumes: finished scenarios return at
once, the others continue, and the table is made again. A node failure reruns
the subjob (-r y), which resumes too.

Examples:
  jobs/pbs/submit-study.sh --ranks 16 --time 12:00:00 --queue workq
  jobs/pbs/submit-study.sh --dry-run -R 20 --set run.t_max=500 jobs/scenarios/1-baseline.toml
EOF
}

study_defaults  # -R 1000, -s 1, -o results, no --set, no scenarios
ranks=4
select_spec=
walltime=24:00:00
queue=
account=
stop_before=120
parsable=0
extra=()

while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --select) need_value "$@"; select_spec=$2; shift 2 ;;
    -t|--time) need_value "$@"; walltime=$2; shift 2 ;;
    -q|--queue) need_value "$@"; queue=$2; shift 2 ;;
    -A|--account) need_value "$@"; account=$2; shift 2 ;;
    --stop-before) need_value "$@"; stop_before=$2; shift 2 ;;
    --qsub) need_value "$@"; extra+=("$2"); shift 2 ;;
    --qsub=*) extra+=("${1#--qsub=}"); shift ;;
    --parsable) parsable=1; shift ;;
    *) take_study_option "$@"; shift "$nargs" ;;  # -R -s -n -o --set --ringsim --dry-run, scenarios
  esac
done

check_study_values
is_count "$stop_before" || die "--stop-before must be a positive number of seconds"
[[ $walltime =~ ^[0-9]+:[0-9]{2}:[0-9]{2}$ ]] || die "--time must be HH:MM:SS, not '$walltime'"
check_sets --one-line  # study.txt has one line per value

resolve_scenarios --absolute  # absolute paths, unique names
n_jobs=${#scenarios[@]}
resolve_ringsim

case "$outdir" in /*) ;; *) outdir=$PWD/$outdir ;; esac
study_file=$outdir/study.txt
[[ $study_file != *,* ]] || die "the output directory must not contain a comma (qsub -v splits on commas): $outdir"

study_text() {
  echo "# ringsim study, read by jobs/pbs/ringsim-scenario.pbs (subjob k runs the k-th scenario)"
  echo "replicates=$replicates"
  echo "seed=$seed"
  echo "outdir=$outdir"
  echo "ringsim=$ringsim"
  for s in "${sets[@]}"; do echo "set=$s"; done
  for f in "${scenarios[@]}"; do echo "scenario=$f"; done
}

common=()
[ -n "$queue" ] && common+=(-q "$queue")
[ -n "$account" ] && common+=(-A "$account")
common+=("${extra[@]}")

array_cmd=(qsub -N ringsim-study
  -l "select=${select_spec:-1:ncpus=$ranks:mpiprocs=$ranks}" -l "walltime=$walltime"
  -r y -j oe -o "$outdir/logs/"
  -v "RINGSIM_STUDY=$study_file,RINGSIM_STOP_BEFORE=$stop_before")
# One scenario is a plain job: some PBS versions reject a one-subjob range.
[ "$n_jobs" -gt 1 ] && array_cmd+=(-J "0-$((n_jobs - 1))")
array_cmd+=("${common[@]}" "$template")

aggregate_script="#!/bin/bash
#PBS -N ringsim-aggregate
exec bash $(printf '%q ' "$repo/jobs/aggregate-study.sh" --ringsim "$ringsim" "$outdir" "${names[@]}")"
aggregate_cmd=(qsub -l select=1:ncpus=1 -l walltime=00:30:00 -j oe -o "$outdir/logs/" "${common[@]}")

if [ "$dry_run" = 1 ]; then
  if [ "$parsable" = 0 ]; then
    echo "# dry run: nothing submitted. $study_file would hold:"
    study_text | sed 's/^/#   /'
  fi
  printf '%q ' "${array_cmd[@]}"; echo
  printf '%q ' "${aggregate_cmd[@]}" -W depend=afterany:ARRAY_JOB_ID; echo " <<'EOF'"
  echo "$aggregate_script"
  echo "EOF"
  exit 0
fi

command -v qsub > /dev/null || die "no qsub here (try --dry-run)"
mkdir -p "$outdir/logs" || die "cannot create $outdir/logs"
study_text > "$study_file"
array_id=$("${array_cmd[@]}") || die "qsub of the job array failed"
if ! aggregate_id=$(echo "$aggregate_script" | "${aggregate_cmd[@]}" -W "depend=afterany:$array_id"); then
  die "qsub of the aggregation job failed; the scenarios run anyway ($array_id); aggregate later: bash $repo/jobs/aggregate-study.sh --ringsim $ringsim $outdir ${names[*]}"
fi

if [ "$parsable" = 1 ]; then
  echo "$array_id $aggregate_id"
  exit 0
fi
echo "ringsim study: $n_jobs scenarios, R=$replicates, seed $seed, walltime $walltime; parameters in $study_file"
for i in "${!scenarios[@]}"; do echo "  subjob $i: ${scenarios[$i]} -> $outdir/${names[$i]}.h5"; done
echo "job array $array_id; aggregation job $aggregate_id (after every subjob): $outdir/table5.md, $outdir/table5.csv"
echo "watch: qstat -t $array_id $aggregate_id"
