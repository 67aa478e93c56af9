#!/usr/bin/env bash
# Table 5 of a study: `ringsim aggregate` over OUTDIR/<name>.h5 of the given
# scenarios, written to OUTDIR/table5.md and OUTDIR/table5.csv (and the
# Markdown table to stdout). The last step of jobs/slurm/submit-study.sh,
# jobs/pbs/submit-study.sh and jobs/local/run-study.sh.
#
#   jobs/aggregate-study.sh [--ringsim PATH] OUTDIR NAME...
#
# Only the named files, not OUTDIR/*.h5 (the directory may hold older
# results); a missing file is listed and the others still make a table. A
# table is replaced only when `ringsim aggregate` succeeded. Exit status 0
# when every file was there and aggregated, 1 otherwise.
set -uo pipefail

ringsim=${RINGSIM:-ringsim}
if [ "${1:-}" = --ringsim ]; then ringsim=$2; shift 2; fi
case "${1:-}" in -h|--help|'') sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;; esac
outdir=$1
shift
[ $# -gt 0 ] || { echo "aggregate-study.sh: no scenario names" >&2; exit 1; }
cd "$outdir" || exit 1

found=()
missing=()
for name in "$@"; do
  if [ -f "$name.h5" ]; then found+=("$name.h5"); else missing+=("$name.h5"); fi
done
if [ ${#found[@]} -eq 0 ]; then
  echo "aggregate-study.sh: none of the result files is in $PWD: ${missing[*]}" >&2
  exit 1
fi

rc=0
for format in markdown csv; do
  ext=$format
  [ "$format" = markdown ] && ext=md
  if "$ringsim" aggregate "${found[@]}" --format "$format" > "table5.$ext.tmp"; then
    mv "table5.$ext.tmp" "table5.$ext"
  else
    rm -f "table5.$ext.tmp"
    echo "aggregate-study.sh: ringsim aggregate --format $format failed" >&2
    rc=1
  fi
done
[ -f table5.md ] && [ $rc = 0 ] && cat table5.md
if [ ${#missing[@]} -gt 0 ]; then
  echo "aggregate-study.sh: missing result files (see the logs): ${missing[*]}" >&2
  rc=1
fi
echo "aggregate-study.sh: $PWD/table5.md, $PWD/table5.csv from ${#found[@]} of $# files" >&2
exit $rc
