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

for name in "${@:-simple office cluttered}"; do
  for n in $name; do
    # shellcheck disable=SC2086  # the drive options are words
    mrs-nav demo ${DRIVE[$n]} --seed 0 --out "$WORK/$n"
    cp "$WORK/$n/session.bag" "$BAGS/$n.bag"
    mrs-nav replay "$BAGS/$n.bag" --plan --plan-iterations 800 --out "$WORK/$n/replay" \
      --write-golden "$BAGS/$n.golden.json"
    echo "$BAGS/$n.bag: $(stat -c %s "$BAGS/$n.bag") bytes, golden $BAGS/$n.golden.json"
  done
done
