# shellcheck shell=bash disable=SC2034  # it sets variables for the drivers
# jobs/lib/common.sh: what the three study drivers share. Sourced (not run)
# by jobs/slurm/submit-study.sh, jobs/pbs/submit-study.sh and
# jobs/local/run-study.sh, relative to their own location:
#
#   here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
#   repo=$(cd "$here/../.." && pwd)
#   . "$repo/jobs/lib/common.sh"
#
# The batch scripts (jobs/slurm/ringsim-scenario.sbatch,
# jobs/pbs/ringsim-scenario.pbs) do not source it: Slurm and PBS run a copy
# of them from a spool directory, where ../lib is not to be found, so they
# stay self-contained.
#
# Sourcing sets `prog`, the sourcing script's file name, which starts every
# message of die(). The functions work on the drivers' variables, which have
# the same names in all three:
#   repo        the checkout (absolute; set by the driver before any call)
#   replicates, seed, ranks, outdir, ringsim, dry_run   the options
#   sets        the --set values (array)
#   scenarios   the scenario files (array); names: their names (array)
#
#   die MESSAGE...          print "$prog: MESSAGE" to stderr, exit 1
#   need_value ARGS...      die unless the option $1 has a value $2
#   is_count VALUE          true for a positive integer (no sign, no leading 0)
#   study_defaults          the defaults of the shared options
#   take_study_option ARGS... parse a shared option or a scenario at the
#                           head of ARGS; sets nargs, the count to shift
#   check_seed              --seed is well-formed
#   check_study_values      --replicates, --seed and --ranks are well-formed
#   check_sets [--one-line] every --set value is KEY=VALUE (and one line)
#   resolve_scenarios [--absolute]  default scenarios, existence, unique names
#   resolve_ringsim [--as-given]    the ringsim executable to run

prog=$(basename "${BASH_SOURCE[1]:-$0}")

die() { echo "$prog: $*" >&2; exit 1; }

# need_value "$@" inside an option parser: $1 is the option, $2 its value.
need_value() { [ $# -ge 2 ] || die "$1 needs a value (see --help)"; }

is_count() { [[ $1 =~ ^[1-9][0-9]*$ ]]; }

# The defaults of the options every driver has (ranks, whose default
# differs, is the driver's own): R = 1000 (MODEL.md, "Protocol"), seed 1.
study_defaults() {
  replicates=1000
  seed=1
  outdir=results
  ringsim=
  dry_run=0
  sets=()
  scenarios=()
}

# take_study_option "$@": the last branch of a driver's option parser. Takes
# -R/--replicates, -s/--seed, -n/--ranks, -o/--outdir, --set, --ringsim,
# --dry-run, `--` (everything after it is a scenario) or a scenario file at
# the head of the arguments, and sets nargs to the number of arguments it
# took, for the caller to `shift "$nargs"`. Any other option is an error.
take_study_option() {
  case "$1" in
    -R|--replicates) need_value "$@"; replicates=$2; nargs=2 ;;
    -s|--seed) need_value "$@"; seed=$2; nargs=2 ;;
    -n|--ranks) need_value "$@"; ranks=$2; nargs=2 ;;
    -o|--outdir) need_value "$@"; outdir=$2; nargs=2 ;;
    --set) need_value "$@"; sets+=("$2"); nargs=2 ;;
    --set=*) sets+=("${1#--set=}"); nargs=1 ;;
    --ringsim) need_value "$@"; ringsim=$2; nargs=2 ;;
    --dry-run) dry_run=1; nargs=1 ;;
    --) nargs=$#; shift; scenarios+=("$@") ;;
    -*) die "unknown option $1 (see --help)" ;;
    *) scenarios+=("$1"); nargs=1 ;;
  esac
}

check_seed() { [[ $seed =~ ^[0-9]+$ ]] || die "--seed must be a non-negative integer, not '$seed'"; }

check_study_values() {
  is_count "$replicates" || die "--replicates must be a positive integer, not '$replicates'"
  check_seed
  is_count "$ranks" || die "--ranks must be a positive integer, not '$ranks'"
}

# check_sets [--one-line]: every --set value must be SECTION.KEY=VALUE; with
# --one-line also free of newlines (PBS's study file has a line per value).
check_sets() {
  local one_line=0 s
  if [ "${1:-}" = --one-line ]; then one_line=1; fi
  for s in "${sets[@]}"; do
    [[ $s == *=* ]] || die "--set needs SECTION.KEY=VALUE, not '$s'"
    if [ "$one_line" = 1 ]; then
      [[ $s != *$'\n'* ]] || die "--set value with a newline: '$s'"
    fi
  done
}

# resolve_scenarios [--absolute]: without scenario arguments, every
# $repo/jobs/scenarios/*.toml in name order. Each file must exist; sets
# names to the file names without .toml, which must differ, since scenario
# <name> writes $outdir/<name>.h5. --absolute makes the scenarios absolute
# paths (the schedulers start the jobs in other directories).
resolve_scenarios() {
  local absolute=0 i f name n
  if [ "${1:-}" = --absolute ]; then absolute=1; fi
  if [ ${#scenarios[@]} -eq 0 ]; then
    shopt -s nullglob
    scenarios=("$repo"/jobs/scenarios/*.toml)
    shopt -u nullglob
    [ ${#scenarios[@]} -gt 0 ] || die "no scenario files in $repo/jobs/scenarios"
  fi
  names=()
  for i in "${!scenarios[@]}"; do
    f=${scenarios[$i]}
    [ -f "$f" ] || die "no scenario file $f"
    if [ "$absolute" = 1 ]; then
      scenarios[i]=$(cd "$(dirname "$f")" && pwd)/$(basename "$f")
    fi
    name=$(basename "$f" .toml)
    for n in "${names[@]}"; do
      [ "$n" != "$name" ] || die "two scenarios are named $name; their results would share $outdir/$name.h5"
    done
    names+=("$name")
  done
}

# resolve_ringsim [--as-given]: without --ringsim, $repo/build/ringsim when it
# exists, else the ringsim on PATH (its absolute path), else, in a dry run,
# plain `ringsim`; none is an error. A --ringsim with a slash must be
# executable (unless in a dry run) and is made absolute. --as-given (a run on
# this machine, where PATH stays the same) keeps PATH's one as `ringsim` and
# a --ringsim as it was given, unchecked.
resolve_ringsim() {
  local as_given=0
  if [ "${1:-}" = --as-given ]; then as_given=1; fi
  if [ -z "$ringsim" ]; then
    if [ -x "$repo/build/ringsim" ]; then ringsim=$repo/build/ringsim
    elif command -v ringsim > /dev/null; then
      if [ "$as_given" = 1 ]; then ringsim=ringsim; else ringsim=$(command -v ringsim); fi
    elif [ "$dry_run" = 1 ]; then ringsim=ringsim
    else die "no ringsim executable: build it (cmake --build build) or pass --ringsim PATH"
    fi
  elif [ "$as_given" = 0 ] && [[ $ringsim == */* ]]; then
    [ -x "$ringsim" ] || [ "$dry_run" = 1 ] || die "--ringsim $ringsim is not executable"
    ringsim=$(cd "$(dirname "$ringsim")" && pwd)/$(basename "$ringsim")
  fi
}

# Stoppable launches (the local drivers). install_stop_traps makes Ctrl-C or
# SIGTERM pass a SIGUSR1 to the running launcher: mpirun forwards it to the
# ranks, ringsim treats it like SIGTERM, and mpirun then exits with the
# ranks' 75 (after a SIGTERM of its own it exits with 1). run_stoppable CMD...
# runs CMD in the background (so the trap runs at once), waits, and sets rc
# to its status, 75 when a stop was requested and it did not end cleanly.
# `stop` is empty until a stop was requested.
stop=
launcher_pid=
on_stop_signal() {
  stop=$1
  echo "$prog: SIG$1: stopping; finished replicates are kept" >&2
  [ -n "$launcher_pid" ] && kill -USR1 "$launcher_pid" 2> /dev/null
}
install_stop_traps() {
  trap 'on_stop_signal INT' INT
  trap 'on_stop_signal TERM' TERM
}
run_stoppable() {
  "$@" &
  launcher_pid=$!
  while kill -0 "$launcher_pid" 2> /dev/null; do wait "$launcher_pid"; done
  wait "$launcher_pid"
  rc=$?
  launcher_pid=
  # a Ctrl-C reaches mpirun from the terminal too, and it may then report 1
  if [ -n "$stop" ] && [ "$rc" -ne 0 ]; then rc=75; fi
}
