#!/usr/bin/env bash
# A one- or two-parameter sweep of one scenario: every combination of the
# --param values is a sweep point (the scenario plus --set overrides, so its
# own configuration hash and row in `ringsim aggregate`), run here under
# mpirun or submitted to Slurm as one job array with a dependent job that
# aggregates and plots. Run with --help.
set -uo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/.." && pwd)
# shellcheck source=jobs/lib/common.sh
. "$repo/jobs/lib/common.sh" || { echo "sweep.sh: cannot read $repo/jobs/lib/common.sh" >&2; exit 1; }

usage() {
  cat <<EOF
sweep.sh: sweep one or two configuration keys of a scenario.

  jobs/sweep.sh [OPTIONS] --param KEY=V1,V2,... [--param KEY=V1,...] [SCENARIO.toml]

A --param KEY may join several keys with '+' to give them the same value,
e.g. bonding.dtheta_deg+bonding.dphi_deg=1,2,5,10,20. Without a scenario the
built-in defaults (Scenario 4) are swept. Point p writes
OUTDIR/<scenario>__<key>=<value>[__...].h5 with
\`ringsim run SCENARIO --set KEY=VALUE ... --resume\`; at the end
OUTDIR/sweep.md, OUTDIR/sweep.csv (\`ringsim aggregate\`) and OUTDIR/sweep.png
(scripts/plot_results.py sweep: each Table 5 observable against the first
--param, one curve per value of the second, 95 % CI error bars).

Options:
  --param KEY=V1,...    swept key(s) and values (one or two --param)
  -R, --replicates R    replicates per point (default 1000)
  -s, --seed S          base seed, the same for every point (default 1)
  -n, --ranks P         MPI ranks per point (default: $(nproc), the cores here)
  -o, --outdir DIR      results directory (default results)
      --set KEY=VALUE   fixed override for every point (repeatable)
      --ringsim PATH    the executable (default: $repo/build/ringsim)
      --mpirun OPTION   extra mpirun option (repeatable), e.g. --mpirun=--oversubscribe
      --slurm           submit as a Slurm job array (one task per point, each with
                        -n tasks, jobs/slurm/ringsim-scenario.sbatch) plus a
                        dependent aggregation and plot job; extra sbatch options
                        with --sbatch OPTION (repeatable), e.g. --sbatch=--time=4:00:00
      --dry-run         print the commands only
  -h, --help            this text

Running the same command again resumes every unfinished point.

Example (the study's demonstration on Scenario 4):
  jobs/sweep.sh -R 100 -o sweep4 jobs/scenarios/4-passive-selection.toml \\
      --param bonding.dtheta_deg+bonding.dphi_deg=1,2,5,10,20 \\
      --param bonding.capture_distance=0.05,0.1,0.2,0.4
EOF
}

study_defaults
ranks=$(nproc)
params=()
mpirun_args=()
sbatch_args=()
slurm=0
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --param) need_value "$@"; params+=("$2"); shift 2 ;;
    --param=*) params+=("${1#--param=}"); shift ;;
    --mpirun) need_value "$@"; mpirun_args+=("$2"); shift 2 ;;
    --mpirun=*) mpirun_args+=("${1#--mpirun=}"); shift ;;
    --sbatch) need_value "$@"; sbatch_args+=("$2"); shift 2 ;;
    --sbatch=*) sbatch_args+=("${1#--sbatch=}"); shift ;;
    --slurm) slurm=1; shift ;;
    *) take_study_option "$@"; shift "$nargs" ;;
  esac
done
check_study_values
check_sets
[ ${#params[@]} -ge 1 ] && [ ${#params[@]} -le 2 ] || die "give one or two --param KEY=V1,V2,... (see --help)"
for p in "${params[@]}"; do
  [[ $p == *=?* ]] || die "--param needs KEY=V1,V2,..., not '$p'"
done
[ ${#scenarios[@]} -le 1 ] || die "one scenario per sweep (got ${#scenarios[@]})"
if [ ${#scenarios[@]} -eq 1 ]; then
  [ -f "${scenarios[0]}" ] || die "no scenario file ${scenarios[0]}"
  scenario=$(cd "$(dirname "${scenarios[0]}")" && pwd)/$(basename "${scenarios[0]}")
  base=$(basename "$scenario" .toml)
else
  scenario=
  base=default
fi
resolve_ringsim
case "$outdir" in /*) ;; *) outdir=$PWD/$outdir ;; esac

# The points: "NAME SET..." per line, the cross product of the --param values.
expand() {  # expand KEYS VALUE: one --set per key joined by '+'
  local keys=$1 value=$2 k
  IFS='+' read -r -a ks <<< "$keys"
  for k in "${ks[@]}"; do printf ' %s=%s' "$k" "$value"; done
}
points=()
IFS=',' read -r -a first <<< "${params[0]#*=}"
second=("")
[ ${#params[@]} -eq 2 ] && IFS=',' read -r -a second <<< "${params[1]#*=}"
for a in "${first[@]}"; do
  for b in "${second[@]}"; do
    name="${base}__${params[0]%%=*}=$a"
    line=$(expand "${params[0]%%=*}" "$a")
    if [ ${#params[@]} -eq 2 ]; then
      name+="__${params[1]%%=*}=$b"
      line+=$(expand "${params[1]%%=*}" "$b")
    fi
    points+=("${name//\//_}$line")
  done
done
files=()
for p in "${points[@]}"; do files+=("$outdir/${p%% *}.h5"); done
echo "sweep.sh: ${#points[@]} points of $base, R = $replicates each" >&2

finish_cmds() {  # the aggregation and plot, as one shell command line
  printf '%q aggregate' "$ringsim"
  printf ' %q' "${files[@]}"
  printf ' --format markdown > %q && ' "$outdir/sweep.md"
  printf '%q aggregate' "$ringsim"
  printf ' %q' "${files[@]}"
  printf ' --format csv > %q && /usr/bin/python3 %q sweep' "$outdir/sweep.csv" "$repo/scripts/plot_results.py"
  printf ' %q' "${files[@]}"
  printf ' -o %q\n' "$outdir/sweep.png"
}

if [ "$slurm" = 1 ]; then
  [ "$dry_run" = 1 ] || mkdir -p "$outdir" || die "cannot create $outdir"
  list=$outdir/sweep-points.txt
  [ "$dry_run" = 1 ] || printf '%s\n' "${points[@]}" > "$list"
  array=(sbatch --parsable --array=0-$((${#points[@]} - 1)) --ntasks="$ranks" "${sbatch_args[@]}"
         --export="ALL,RINGSIM_POINTS=$list,RINGSIM_OUTDIR=$outdir,RINGSIM_REPLICATES=$replicates,RINGSIM_SEED=$seed,RINGSIM=$ringsim,RINGSIM_SET=${sets[*]}"
         "$repo/jobs/slurm/ringsim-scenario.sbatch")
  [ -n "$scenario" ] && array+=("$scenario")
  if [ "$dry_run" = 1 ]; then
    printf '%q ' "${array[@]}"; echo
    echo "sbatch --dependency=afterany:<array job> --wrap $(finish_cmds | sed 's/.*/"&"/')"
    exit 0
  fi
  id=$("${array[@]}") || die "sbatch of the array failed"
  fin=$(sbatch --parsable --dependency="afterany:$id" --job-name=ringsim-sweep-aggregate "${sbatch_args[@]}" \
        --output="$outdir/sweep-aggregate-%j.log" --wrap "$(finish_cmds)") || die "sbatch of the aggregation failed"
  echo "sweep.sh: array job $id (${#points[@]} tasks), aggregation job $fin; results in $outdir" >&2
  exit 0
fi

# Here: each point under mpirun in turn; Ctrl-C / SIGTERM stop cleanly (75).
install_stop_traps
[ "$dry_run" = 1 ] || mkdir -p "$outdir" || die "cannot create $outdir"
failed=0
for i in "${!points[@]}"; do
  [ -z "$stop" ] || break
  read -r -a fields <<< "${points[$i]}"
  cmd=(mpirun -np "$ranks" "${mpirun_args[@]}" "$ringsim" run)
  [ -n "$scenario" ] && cmd+=("$scenario")
  cmd+=(--replicates "$replicates" --seed "$seed" -o "${files[$i]}" --resume --progress none)
  for s in "${sets[@]}" "${fields[@]:1}"; do cmd+=(--set "$s"); done
  if [ "$dry_run" = 1 ]; then printf '%q ' "${cmd[@]}"; echo; continue; fi
  echo "sweep.sh: [$((i + 1))/${#points[@]}] ${fields[0]}" >&2
  run_stoppable "${cmd[@]}" > /dev/null  # the per-point table; the sweep table follows
  case "$rc" in
    0) ;;
    75) stop=${stop:-ranks} ;;
    *) failed=1; echo "sweep.sh: ${fields[0]} failed (exit $rc); going on" >&2 ;;
  esac
done
if [ "$dry_run" = 1 ]; then finish_cmds; exit 0; fi
trap - INT TERM
if [ -n "$stop" ]; then
  echo "sweep.sh: stopped; run the same command again to resume" >&2
  exit 75
fi
bash -c "$(finish_cmds)" || die "aggregation or plot failed"
cat "$outdir/sweep.md"
echo "sweep.sh: $outdir/sweep.md, $outdir/sweep.csv, $outdir/sweep.png" >&2
exit $failed
