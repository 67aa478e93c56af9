#!/usr/bin/env bash
# Fails when a file of the repository refers to a path outside it: the
# sibling folder of shared specifications next to the development checkout,
# or an absolute path of the development machine (the patterns are built
# below). A user's clone has neither.
#
# Usage: check_self_contained.sh [REPO_DIR]   (default: the repository of this
# script). Lists the tracked files with `git ls-files` when REPO_DIR is a git
# work tree, else every file under it (build directories and .git skipped).
# This script is the only file exempt: it has to name the patterns.
set -euo pipefail
repo=${1:-"$(cd "$(dirname "$0")/.." && pwd)"}
cd "$repo"
self="tests/check_self_contained.sh"

# The patterns are assembled so that this file does not contain them verbatim.
dotdot=".."
patterns=("${dotdot}/shared" "/wo""rk/")

if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  mapfile -d '' files < <(git ls-files -z)
else
  mapfile -d '' files < <(find . -type d \( -name .git -o -name 'build*' \) -prune -o -type f -print0 | sed -z 's|^\./||')
fi

# One grep over every file but this one (-I: binary files skipped; -F: the
# patterns are literals); files listed but absent (deleted, not committed)
# are dropped first.
checked=()
for f in "${files[@]}"; do
  [ "$f" != "$self" ] && [ -f "$f" ] && checked+=("$f")
done
found=0
if [ "${#checked[@]}" -gt 0 ]; then
  args=()
  for p in "${patterns[@]}"; do args+=(-e "$p"); done
  # Judged by the output: xargs may run grep in batches, and any batch with
  # no match makes its status non-zero.
  hits=$(printf '%s\0' "${checked[@]}" | xargs -0 grep -nIHF "${args[@]}" -- || true)
  if [ -n "$hits" ]; then
    echo "$hits"
    found=1
  fi
fi

if [ "$found" -ne 0 ]; then
  echo "FAIL: the files above refer to paths outside the repository (${patterns[*]})" >&2
  exit 1
fi
echo "OK: ${#checked[@]} files, none refers to ${patterns[*]}"
