#!/bin/sh
# Usage: check_report.sh ROLLSTEP EXPERIMENTS OUT_DIR
# A short `rollstep report`: a passing trot on flat and a step20 run too short to climb.
# Checks the report's files, that the failed run is shown as failed with its reason and no
# invented numbers, the acceptance verdict, and --check's exit status.
rollstep=$1
experiments=$2
out=$3
rm -rf "$out" "$out.again"
mkdir -p "$(dirname "$out")"
fail() { echo "FAIL: $*"; exit 1; }
"$rollstep" report --out "$out" --experiments "$experiments" --check > "$out.stdout" 2> "$out.stderr"
rc=$?
cat "$out.stdout"
[ $rc -eq 3 ] || fail "--check with a failed run: expected exit status 3, got $rc"
for f in report.md report.html figures.json runs/flat_trot/log.csv runs/flat_trot/mpc.csv \
    runs/step20_short/log.csv; do
  [ -s "$out/$f" ] || fail "missing $f"
done
md="$out/report.md"
grep -q '| flat_trot | trot on flat | perception (LiDAR, closed loop) | passed |' "$md" \
  || fail "flat_trot not shown as passed on perception"
grep -q '| step20_short | step20, too short to climb | scene ground truth | \*\*FAILED\*\* | did not traverse the step: the MF wheel never landed on the step |' "$md" \
  || fail "step20_short not shown as failed with its reason"
grep -q '| step20, too short to climb | not measured | 14 | not measured | 0.021 | not measured | 0.056 |' "$md" \
  || fail "Table 1 row of the failed run: expected 'not measured' beside the paper's figures"
grep -q 'Not met' "$md" || fail "acceptance verdict missing"
grep -q 'Version: ' "$md" || fail "version missing"
grep -q 'rollstep sim --spec .*/runs/flat_trot/spec.yaml' "$md" \
  || fail "the run's exact command is missing"
grep -q '^terrain: perception$' "$md" || fail "the run's spec is missing"
[ -s "$out/runs/flat_trot/map/maps.csv" ] || fail "the perception run left no map log"
grep -q '<table>' "$out/report.html" || fail "report.html has no table"
# Figures: drawn, or stated as not available (never silently missing).
for fig in fig2 fig4 fig6 fig8 map; do
  [ -s "$out/$fig.png" ] || grep -q "Figure not available" "$md" || fail "$fig neither drawn nor stated"
done
# Fig. 6's caption says what an update of its run did, read from the run's own outputs.
if [ -s "$out/fig6.png" ]; then
  grep -q 'Wall time of each MPC update over the run (flat_trot: N = 100, 3 real-time iterations per update)' "$md" \
    || fail "Fig. 6's caption does not give flat_trot's horizon and iterations per update"
fi
# Pictures: made, or stated as not available with a warning.
if [ -s "$out/snapshots_flat_trot.png" ]; then
  echo "snapshots: made"
else
  grep -q "Snapshots not available" "$md" || fail "snapshots neither made nor stated"
  grep -q "warning: snapshots and videos not available" "$out.stderr" || fail "no warning"
fi
if [ -s "$out/video_flat_trot.mp4" ]; then
  echo "video: made"
else
  grep -q "Videos not available" "$md" || fail "video neither made nor stated"
fi
[ -e "$out/video_step20_short.mp4" ] && fail "video made for a scenario with video: false"
# Re-running gives the same numbers: the same run again, its log byte for byte.
"$rollstep" report --out "$out.again" --experiments "$experiments" --only step20_short \
  --no-videos > /dev/null 2>&1 || fail "the second report"
cmp -s "$out/runs/step20_short/log.csv" "$out.again/runs/step20_short/log.csv" \
  || fail "re-running changed step20_short's log"
grep -q '| step20_short | step20, too short to climb | scene ground truth | \*\*FAILED\*\* | did not traverse' "$out.again/report.md" \
  || fail "the second report differs"
echo "report check passed"
