#!/bin/sh
# The replay page of a short nmpc run in headless Chromium (ctest label browser):
#   browser_replay.sh ROLLSTEP NODE_MODULES CHECK_SCRIPT OUT [SIM OPTIONS...]
# SIM OPTIONS replace the run's scene (default: --scene step20), e.g. --robot wheelquad.
# Skipped (77) only without chromium.
set -eu
rollstep=$1 node_modules=$2 check=$3 out=$4
shift 4
[ $# -gt 0 ] || set -- --scene step20
if [ ! -x "${CHROMIUM:-/usr/bin/chromium}" ]; then
  echo "browser check skipped: chromium not found (Debian package chromium)"
  exit 77
fi
rm -rf "$out"
"$rollstep" sim "$@" --controller nmpc --gait trot --vx 0.15 --duration 2 \
  --mpc-timing deterministic --out "$out" > /dev/null
for f in replay.json plan.csv.gz; do
  [ -s "$out/$f" ] || { echo "FAIL: rollstep sim wrote no $out/$f"; exit 1; }
done
"$rollstep" view "$out"
NODE_PATH="$node_modules" node "$check" replay "$out/replay.html"
