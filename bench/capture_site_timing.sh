#!/usr/bin/env bash
# Wall time of one full-protocol replicate with each capture reading
# (bonding.capture_site = end_face, end_point), measured side by side
# (bench/paired_timing.sh): per scenario the median of each reading and
# their ratio face/point.
#
# Usage: bench/capture_site_timing.sh RINGSIM SEEDS SCENARIO...
#   e.g. bench/capture_site_timing.sh build/ringsim "1 2 3" 1-baseline 4-passive-selection
set -euo pipefail
if [[ $# -lt 3 ]]; then sed -n '2,8p' "$0"; exit 1; fi
bin=$1 seeds=$2
shift 2
exec "$(dirname "$0")/paired_timing.sh" "$bin" "$seeds" bonding.capture_site end_face end_point "$@"
