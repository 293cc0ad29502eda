#!/bin/sh
# rollstep view --map: the replay page of a perception run whose map log is not DIR/map
# carries the map's snapshots; without --map it has none; a --map folder that is not a map
# log is refused before anything is written.
#   check_view_map.sh ROLLSTEP OUT
set -u
rollstep=$1 out=$2
rm -rf "$out"
"$rollstep" sim --scene flat --controller nmpc --terrain perception --duration 0.5 \
  --mpc-timing deterministic --log-map "$out/maplog" --out "$out/run" > /dev/null ||
  { echo "FAIL: the perception run"; exit 1; }
"$rollstep" view "$out/run" > /dev/null || { echo "FAIL: view without --map"; exit 1; }
grep -q '"maps":null' "$out/run/replay.html" || { echo "FAIL: a map without --map"; exit 1; }
"$rollstep" view "$out/run" --map "$out/maplog" > /dev/null || { echo "FAIL: view --map"; exit 1; }
grep -q '"maps":\[{"heights":' "$out/run/replay.html" ||
  { echo "FAIL: no map snapshots with --map"; exit 1; }
cp "$out/run/replay.html" "$out/page_before"
err=$("$rollstep" view "$out/run" --map "$out/run" 2>&1)
[ $? -ne 0 ] || { echo "FAIL: a folder without maps.csv accepted"; exit 1; }
echo "$err" | grep -q "map log '$out/run': no maps.csv" || { echo "FAIL: message: $err"; exit 1; }
cmp -s "$out/page_before" "$out/run/replay.html" || { echo "FAIL: the page changed"; exit 1; }
err=$("$rollstep" view "$out/run" --map "$out/nonexistent" 2>&1)
[ $? -ne 0 ] || { echo "FAIL: a missing --map folder accepted"; exit 1; }
echo "$err" | grep -q "is not a directory" || { echo "FAIL: message: $err"; exit 1; }
echo "view --map check passed"
