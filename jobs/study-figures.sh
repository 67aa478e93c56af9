#!/usr/bin/env bash
# The figures of a finished (or partial) study in OUTDIR: the ring-size
# distributions of every scenario's result file, N_t(t) with the MSER cut
# of replicate 0 of each scenario, and a rendered final configuration of
# replicate 0 of each. Run with --help.
set -uo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/.." && pwd)
# shellcheck source=jobs/lib/common.sh
. "$repo/jobs/lib/common.sh" || { echo "study-figures.sh: cannot read $repo/jobs/lib/common.sh" >&2; exit 1; }

usage() {
  cat <<EOF
study-figures.sh: the figures of a study run by jobs/local/run-study.sh (or
the Slurm/PBS submitters) into OUTDIR.

  jobs/study-figures.sh [OPTIONS] OUTDIR [SCENARIO.toml...]

Without scenarios, every file in jobs/scenarios/ whose OUTDIR/<name>.h5
exists. Writes into OUTDIR/figures/:
  rings.png        ring-size distribution per scenario, from OUTDIR/<name>.h5
                   (scripts/plot_results.py rings)
  nt_series.png    N_t(t) of replicate 0 of each scenario with its MSER cut:
                   replicate 0 is run again as a one-replicate ensemble with
                   --series (<name>_r0.h5; the same random streams as the
                   study's replicate 0, so the same trajectory)
  <name>.xyz/.png  final configuration of replicate 0, from
                   \`ringsim replicate --snapshot\`, rendered by
                   scripts/render_snapshot.py; <name>_r0.json its observables
and checks that the re-runs reproduce the study's replicate 0 (N_t, bonds).

Options:
  -s, --seed S        the study's base seed (default 1)
  -j, --jobs J        re-runs at a time (default: $(nproc), the cores here)
      --set KEY=VALUE the study's overrides (repeatable; must match the study's)
      --ringsim PATH  the executable (default: $repo/build/ringsim when it
                      exists, else \`ringsim\` on PATH)
      --no-rerun      only the ring plot (no replicate re-runs)
  -h, --help          this text
Files that already exist are not made again (delete them to redo one).
EOF
}

study_defaults
jobs=$(nproc)
rerun=1
outdir=
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    -j|--jobs) need_value "$@"; jobs=$2; shift 2 ;;
    --no-rerun) rerun=0; shift ;;
    -R|--replicates|-n|--ranks|-o|--outdir|--dry-run) die "$1 is not an option of this script (see --help)" ;;
    *) if [ -z "$outdir" ] && [[ $1 != -* ]]; then outdir=$1; shift
       else take_study_option "$@"; shift "$nargs"; fi ;;
  esac
done
[ -n "$outdir" ] || die "no OUTDIR (see --help)"
[ -d "$outdir" ] || die "OUTDIR $outdir is not a directory"
is_count "$jobs" || die "--jobs must be a positive integer, not '$jobs'"
check_seed
check_sets
explicit=${#scenarios[@]}
resolve_scenarios
resolve_ringsim --as-given
py=/usr/bin/python3

# Scenarios with a result file (all given ones must have one).
files=()
todo=()
for i in "${!scenarios[@]}"; do
  h5=$outdir/${names[$i]}.h5
  if [ -f "$h5" ]; then files+=("$h5"); todo+=("$i")
  elif [ "$explicit" -gt 0 ]; then die "no result file $h5"
  fi
done
[ ${#files[@]} -gt 0 ] || die "no result file of any scenario in $outdir"
fig=$outdir/figures
mkdir -p "$fig" || die "cannot create $fig"

"$py" "$repo/scripts/plot_results.py" rings "${files[@]}" -o "$fig/rings.png" || die "ring plot failed"
[ "$rerun" = 1 ] || exit 0

set_args=()
for s in "${sets[@]}"; do set_args+=(--set "$s"); done
# The re-runs, $jobs at a time as background jobs (set_args stays an array).
rerun_one() {
  local kind=$1 file=$2 name=$3
  case "$kind" in
    series)
      [ -f "$fig/${name}_r0.h5" ] && return 0
      "$ringsim" run "$file" --replicates 1 --seed "$seed" --series --progress none \
        -o "$fig/${name}_r0.h5.part" "${set_args[@]}" > "$fig/${name}_r0.log" 2>&1 &&
        mv "$fig/${name}_r0.h5.part" "$fig/${name}_r0.h5" ;;
    snapshot)
      [ -f "$fig/${name}_r0.json" ] && return 0
      "$ringsim" replicate "$file" --seed "$seed" --replicate 0 --json --snapshot "$fig/$name.xyz" \
        "${set_args[@]}" > "$fig/${name}_r0.json.part" &&
        mv "$fig/${name}_r0.json.part" "$fig/${name}_r0.json" ;;
  esac
}
failed=0
running=0
for i in "${todo[@]}"; do
  for kind in series snapshot; do
    if [ "$running" -ge "$jobs" ]; then
      wait -n || failed=1
      running=$((running - 1))
    fi
    rerun_one "$kind" "${scenarios[$i]}" "${names[$i]}" &
    running=$((running + 1))
  done
done
while [ "$running" -gt 0 ]; do
  wait -n || failed=1
  running=$((running - 1))
done
[ "$failed" = 0 ] || die "a re-run failed (see above and $fig/*_r0.log)"

series=()
for i in "${todo[@]}"; do series+=("$fig/${names[$i]}_r0.h5"); done
"$py" "$repo/scripts/plot_results.py" series "${series[@]}" -o "$fig/nt_series.png" || die "series plot failed"
status=0
for i in "${todo[@]}"; do
  name=${names[$i]}
  [ -f "$fig/$name.png" ] || "$py" "$repo/scripts/render_snapshot.py" "$fig/$name.xyz" -o "$fig/$name.png" ||
    die "rendering $fig/$name.xyz failed"
  # The re-run must be the study's replicate 0.
  "$py" - "$outdir/$name.h5" "$fig/${name}_r0.json" <<'EOF' || status=1
import json, sys
import h5py
with h5py.File(sys.argv[1], "r") as f:
    rows = f["replicates"][()]
row = rows[(rows["id"] == 0) & (rows["status"] == 1)]
rerun = json.load(open(sys.argv[2]))
if len(row) == 0:
    print(f"{sys.argv[1]}: replicate 0 not finished; not compared")
    sys.exit(0)
same = all(int(row[k][0]) == int(rerun[k]) for k in ("N_t", "bonds", "events"))
print(f"{sys.argv[1]}: replicate 0 re-run {'reproduces' if same else 'DIFFERS FROM'} the study's "
      f"(N_t {int(row['N_t'][0])} / {rerun['N_t']}, bonds {int(row['bonds'][0])} / {rerun['bonds']}, "
      f"events {int(row['events'][0])} / {rerun['events']})")
sys.exit(0 if same else 1)
EOF
done
echo "study-figures.sh: $fig/rings.png, $fig/nt_series.png and one PNG per scenario" >&2
exit "$status"
