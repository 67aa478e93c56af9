#!/usr/bin/env bash
# jobs/study-figures.sh on a tiny study: the figures are written, the
# re-runs of replicate 0 reproduce the study's, and a re-run with another
# seed is caught (exit 1). Needs mpirun (the study driver) and Debian's
# /usr/bin/python3 with h5py and matplotlib.
set -uo pipefail
RINGSIM=$1
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [ "$(id -u)" = 0 ]; then export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1; fi
small=(--set init.spheres=40 --set init.linkers=40 --set geometry.box_length=20 --set run.t_max=20)
fail() { echo "FAIL: $*" >&2; exit 1; }

"$repo/jobs/local/run-study.sh" -R 2 -n 1 -s 5 -o "$tmp/s" --ringsim "$RINGSIM" "${small[@]}" \
  "$repo/jobs/scenarios/1-baseline.toml" "$repo/jobs/scenarios/4-passive-selection.toml" \
  > "$tmp/study.log" 2>&1 || { cat "$tmp/study.log"; fail "run-study.sh"; }

out=$("$repo/jobs/study-figures.sh" -s 5 -j 2 --ringsim "$RINGSIM" "${small[@]}" "$tmp/s" 2>&1) ||
  { echo "$out"; fail "study-figures.sh exited $?"; }
for f in rings.png nt_series.png 1-baseline.png 4-passive-selection.png; do
  [ -s "$tmp/s/figures/$f" ] || fail "no $f"
done
[ "$(grep -c "re-run reproduces the study's" <<< "$out")" = 2 ] || { echo "$out"; fail "re-runs not reproduced"; }

# Another seed is another replicate 0: the check must catch it (existing
# figures are kept, so remove scenario 1's first).
rm -f "$tmp/s/figures/1-baseline"*
"$repo/jobs/study-figures.sh" -s 6 --ringsim "$RINGSIM" "${small[@]}" "$tmp/s" \
  "$repo/jobs/scenarios/1-baseline.toml" > "$tmp/bad.log" 2>&1
rc=$?
[ "$rc" = 1 ] || { cat "$tmp/bad.log"; fail "a re-run with another seed was not reported (exit $rc)"; }
grep -q "DIFFERS FROM" "$tmp/bad.log" || { cat "$tmp/bad.log"; fail "no DIFFERS message"; }

"$repo/jobs/study-figures.sh" "$tmp/nowhere" > "$tmp/err.log" 2>&1 && fail "a missing OUTDIR was accepted"
grep -q "is not a directory" "$tmp/err.log" || { cat "$tmp/err.log"; fail "unclear message for a missing OUTDIR"; }
echo "study_figures: ok"
