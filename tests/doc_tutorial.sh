#!/usr/bin/env bash
# docs/TUTORIAL.md, run as written: every ```sh block in document order, in
# one bash session (set -euo pipefail), at tiny size. A block whose fence
# follows a line `<!-- doctest: skip (REASON) -->` is shown and skipped.
#
#   tests/doc_tutorial.sh PATH/TO/ringsim [--keep] [--sizes 'R=4 R_SWEEP=4 TMAX=500']
#
# The blocks run in a fresh temporary directory that looks like a clone: every
# top-level entry of this repository linked in, `build` linked to the
# directory of the given ringsim, so `./build/ringsim`, `jobs/...` and
# `scripts/...` work and everything the tutorial writes (`tutorial/`) lands
# in the temporary directory. The sizes come from the variables of the
# tutorial's first block (`R=${R:-1000}` ...), which keep a value set before:
# this script exports the tiny ones (R=2 R_SWEEP=2 TMAX=20 NP=2; --sizes
# replaces them, e.g. to make the outputs the page shows). --keep keeps the
# temporary directory and prints its path. Exit 0 when every block exits 0;
# else the whole output, the failing block and its status. Needs mpirun
# (2 ranks, oversubscribed if need be) and Debian's /usr/bin/python3 with
# h5py, pandas and matplotlib.
set -uo pipefail

usage() { echo "usage: $0 PATH/TO/ringsim [--keep] [--sizes 'R=2 R_SWEEP=2 TMAX=20 NP=2']" >&2; exit 2; }
[ $# -ge 1 ] && [ -x "$1" ] || usage
ringsim=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
shift
keep=0
sizes='R=2 R_SWEEP=2 TMAX=20 NP=2'
while [ $# -gt 0 ]; do
  case "$1" in
    --keep) keep=1; shift ;;
    --sizes) [ $# -ge 2 ] || usage; sizes=$2; shift 2 ;;
    *) usage ;;
  esac
done
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
doc=$repo/docs/TUTORIAL.md
[ -f "$doc" ] || { echo "FAIL: no $doc" >&2; exit 1; }

tmp=$(mktemp -d)
if [ "$keep" = 1 ]; then echo "doc_tutorial: keeping $tmp" >&2; else trap 'rm -rf "$tmp"' EXIT; fi
work=$tmp/clone
mkdir -p "$work" "$tmp/blocks"
for e in "$repo"/* "$repo"/.[!.]*; do
  [ -e "$e" ] || continue
  name=$(basename "$e")
  case "$name" in build|.git) continue ;; esac
  ln -s "$e" "$work/$name"
done
[ "$(basename "$ringsim")" = ringsim ] || { echo "FAIL: the tutorial runs ./build/ringsim; $ringsim is named otherwise" >&2; exit 1; }
ln -s "$(dirname "$ringsim")" "$work/build"

# Split the document: blocks/NNN.sh per ```sh block, NNN.skip when marked;
# blocks/index lines "NNN LINE run|skip REASON".
awk -v dir="$tmp/blocks" '
  /^```sh[[:space:]]*$/ && !inside {
    inside = 1; n++; file = sprintf("%s/%03d.sh", dir, n)
    printf "" > file
    state = (marker != "") ? "skip " marker : "run"
    printf "%03d %d %s\n", n, NR, state >> (dir "/index")
    marker = ""; next
  }
  /^```[[:space:]]*$/ && inside { inside = 0; close(file); next }
  inside { print >> file; next }
  /^<!-- doctest: skip/ { m = $0; sub(/^<!-- doctest: skip[[:space:]]*/, "", m); sub(/[[:space:]]*-->.*$/, "", m)
                          marker = (m == "") ? "(no reason)" : m; next }
  /^[[:space:]]*$/ { next }   # a blank line between the marker and the fence keeps the marker
  { marker = "" }
  END { if (inside) { print "unclosed ```sh block" > "/dev/stderr"; exit 1 } }
' "$doc" || { echo "FAIL: cannot split $doc" >&2; exit 1; }
[ -s "$tmp/blocks/index" ] || { echo "FAIL: no \`\`\`sh block in $doc" >&2; exit 1; }

# The driver: the tiny sizes, then every block sourced in order in one shell.
driver=$tmp/driver.sh
{
  echo 'set -euo pipefail'
  # Tiny sizes (the tutorial's first block keeps values set before it).
  echo "export $sizes"
  # 2 ranks also on a 1-core machine (running as root is the tutorial's job).
  echo 'export OMPI_MCA_rmaps_base_oversubscribe=1'
  # matplotlib without a display and without a writable home
  echo "export MPLBACKEND=Agg MPLCONFIGDIR='$tmp/mpl'"
  echo "cd '$work'"
  while read -r n line state reason; do
    if [ "$state" = skip ]; then
      printf 'echo %q\n' "=== block $n (line $line): skipped $reason"
    else
      echo "echo $n > '$tmp/current'"
      echo "echo '=== block $n (line $line)'"
      echo "source '$tmp/blocks/$n.sh'"
    fi
  done < "$tmp/blocks/index"
  echo "echo done > '$tmp/current'"
} > "$driver"

start=$(date +%s)
bash "$driver" < /dev/null > "$tmp/log" 2>&1
rc=$?
elapsed=$(( $(date +%s) - start ))
cur=$(cat "$tmp/current" 2>/dev/null || echo none)
if [ "$rc" != 0 ] || [ "$cur" != done ]; then
  cat "$tmp/log"
  echo
  if [ -f "$tmp/blocks/$cur.sh" ]; then
    line=$(awk -v n="$cur" '$1 == n { print $2 }' "$tmp/blocks/index")
    echo "FAIL: block $cur of docs/TUTORIAL.md (fence at line $line) exited $rc:" >&2
    sed 's/^/    /' "$tmp/blocks/$cur.sh" >&2
  else
    echo "FAIL: the tutorial's blocks exited $rc (block: $cur)" >&2
  fi
  exit 1
fi
runs=$(grep -c ' run$' "$tmp/blocks/index")
skips=$(grep -c ' skip ' "$tmp/blocks/index")
grep '^=== block' "$tmp/log"
echo "doc_tutorial: ok, $runs blocks ran, $skips skipped, ${elapsed} s"
