#!/usr/bin/env bash
# The whole study without a scheduler: every scenario in turn under mpirun,
# then Table 5 (OUTDIR/table5.md, OUTDIR/table5.csv). Run with --help.
set -uo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
# die, need_value, is_count, the shared options, scenarios and executable
# shellcheck source=jobs/lib/common.sh
. "$repo/jobs/lib/common.sh" || { echo "run-study.sh: cannot read $repo/jobs/lib/common.sh" >&2; exit 1; }

usage() {
  cat <<EOF
run-study.sh: run the ringsim study on this machine, one scenario after the
other over all ranks, then aggregate.

  jobs/local/run-study.sh [OPTIONS] [SCENARIO.toml...]

Without scenarios, every file in jobs/scenarios/ in name order. Each runs as
\`mpirun -np P ringsim run SCENARIO --replicates R --seed S
-o OUTDIR/<scenario>.h5 --resume\`; then jobs/aggregate-study.sh writes
OUTDIR/table5.md and OUTDIR/table5.csv and prints the table.

Options:
  -R, --replicates R    replicates per scenario (default 1000, the study's)
  -s, --seed S          base seed, the same for every scenario (default 1)
  -n, --ranks P         MPI ranks (default: the number of cores, $(nproc) here)
  -o, --outdir DIR      results directory (default results)
      --set KEY=VALUE   configuration override for every scenario (repeatable)
      --ringsim PATH    the executable (default: $repo/build/ringsim
                        when it exists, else \`ringsim\` on PATH)
      --mpirun OPTION   extra mpirun option (repeatable), e.g. --mpirun=--oversubscribe
                        for more ranks than cores, --mpirun=--allow-run-as-root
      --dry-run         print the commands only
  -h, --help            this text

Ctrl-C (or SIGTERM) stops cleanly: the ranks save every finished replicate,
the table is made from what is there, and the script exits with 75. Running
the same command again resumes where it stopped; finished scenarios return
at once. A scenario that fails (configuration or scene error) does not stop
the others; the exit status is then 1.

Examples:
  jobs/local/run-study.sh -R 20 --set run.t_max=500 -o quick
  jobs/local/run-study.sh -n 2 jobs/scenarios/1-baseline.toml jobs/scenarios/4-passive-selection.toml
EOF
}

study_defaults  # -R 1000, -s 1, -o results, no --set, no scenarios
ranks=$(nproc)
mpirun_args=()

while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --mpirun) need_value "$@"; mpirun_args+=("$2"); shift 2 ;;
    --mpirun=*) mpirun_args+=("${1#--mpirun=}"); shift ;;
    *) take_study_option "$@"; shift "$nargs" ;;  # -R -s -n -o --set --ringsim --dry-run, scenarios
  esac
done

check_study_values
# Paths and the executable as given: everything runs here, from this directory.
resolve_scenarios
resolve_ringsim --as-given

install_stop_traps  # Ctrl-C / SIGTERM: SIGUSR1 to mpirun, finished replicates kept (common.sh)

[ "$dry_run" = 1 ] || mkdir -p "$outdir" || die "cannot create $outdir"
failed=()
for i in "${!scenarios[@]}"; do
  [ -z "$stop" ] || break
  cmd=(mpirun -np "$ranks" "${mpirun_args[@]}" "$ringsim" run "${scenarios[$i]}"
       --replicates "$replicates" --seed "$seed" -o "$outdir/${names[$i]}.h5" --resume)
  for s in "${sets[@]}"; do cmd+=(--set "$s"); done
  if [ "$dry_run" = 1 ]; then printf '%q ' "${cmd[@]}"; echo; continue; fi
  echo "run-study.sh: [$((i + 1))/${#scenarios[@]}] ${names[$i]}" >&2
  run_stoppable "${cmd[@]}"
  case "$rc" in
    0) ;;
    75) stop=${stop:-ranks}; echo "run-study.sh: ${names[$i]} stopped early (exit 75)" >&2 ;;
    *) failed+=("${names[$i]}"); echo "run-study.sh: ${names[$i]} failed (exit $rc); going on" >&2 ;;
  esac
done

aggregate=(bash "$repo/jobs/aggregate-study.sh" --ringsim "$ringsim" "$outdir" "${names[@]}")
if [ "$dry_run" = 1 ]; then printf '%q ' "${aggregate[@]}"; echo; exit 0; fi
trap - INT TERM
"${aggregate[@]}"
agg_rc=$?

if [ -n "$stop" ]; then
  echo "run-study.sh: stopped; run the same command again to resume" >&2
  exit 75
fi
if [ ${#failed[@]} -gt 0 ]; then
  echo "run-study.sh: failed: ${failed[*]}" >&2
  exit 1
fi
exit $agg_rc
