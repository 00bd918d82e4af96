#!/usr/bin/env bash
# Re-record the regression bags in tests/data/bags with `mrs-nav demo` (simulator + SLAM + RRT* navigation,
# recording the topics of launch/record.launch) and write their golden files with `mrs-nav replay`.
# Usage: tools/record_regression_bags.sh [NAME...]   (default: simple office cluttered)
set -euo pipefail
cd "$(dirname "$0")/.."
BAGS=tests/data/bags
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

declare -A DRIVE=(
  [simple]="--world simple"
  [office]="--world office --goals=2,-2"
  [cluttered]="--world cluttered"
)

# Replays use the SLAM node's parameters (config/slam.yaml), as the demo and the live node do.
read -r -a PARAMS <<< "$(python - <<'PY'
import dataclasses, yaml
from mrs_nav.slam.config import SlamConfig
values = yaml.safe_load(open("config/slam.yaml"))
print(" ".join(f"--param={k}={v}" for k, v in values.items() if k in {f.name for f in dataclasses.fields(SlamConfig)}))
PY
)"

for name in "${@:-simple office cluttered}"; do
  for n in $name; do
    # shellcheck disable=SC2086  # the drive options are words
    mrs-nav demo ${DRIVE[$n]} --seed 0 --out "$WORK/$n"
    cp "$WORK/$n/session.bag" "$BAGS/$n.bag"
    mrs-nav replay "$BAGS/$n.bag" --plan --plan-first --plan-iterations 3000 "${PARAMS[@]}" --out "$WORK/$n/replay" \
      --write-golden "$BAGS/$n.golden.json"
    echo "$BAGS/$n.bag: $(stat -c %s "$BAGS/$n.bag") bytes, golden $BAGS/$n.golden.json"
  done
done
