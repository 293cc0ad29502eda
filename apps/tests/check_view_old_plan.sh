#!/bin/sh
# rollstep view on an older run's plan log: plan.csv, uncompressed, its positions written
# with four decimals (the writer's first format; same columns), gives the page the same
# plans as the run's plan.csv.gz; a malformed plan.csv is refused naming the file and what
# is wrong, the page left as it was.
#   check_view_old_plan.sh ROLLSTEP OUT
set -u
rollstep=$1 out=$2
rm -rf "$out"
"$rollstep" sim --scene flat --controller nmpc --gait trot --vx 0.1 --duration 0.3 \
  --out "$out/run" > /dev/null || { echo "FAIL: the run"; exit 1; }
planOf() {  # the page's plan data (one JSON object without nested objects)
  sed -n 's/.*"plan":\({[^}]*}\).*/\1/p' "$1"
}
"$rollstep" view "$out/run" > /dev/null || { echo "FAIL: view of the run"; exit 1; }
planOf "$out/run/replay.html" > "$out/plan_gz"
grep -q '"rows_per_solution":\[' "$out/plan_gz" || { echo "FAIL: no plan on the page"; exit 1; }
# The older format: times and positions "%.4f", sequence and mode "%.0f".
gunzip -c "$out/run/plan.csv.gz" | awk -F, 'BEGIN { OFS = "," }
  NR == 1 { print; next }
  { line = sprintf("%.4f,%.4f,%.0f,%.0f", $1, $2, $3, $4)
    for (i = 5; i <= NF; ++i) line = line sprintf(",%.4f", $i)
    print line }' > "$out/plan.csv"
grep -q '^[0-9.]*,[0-9.]*,[0-9]*,[0-9]*,-*[0-9]*\.[0-9][0-9][0-9][0-9],' "$out/plan.csv" ||
  { echo "FAIL: the older plan.csv was not written"; exit 1; }
rm "$out/run/plan.csv.gz"
cp "$out/plan.csv" "$out/run/plan.csv"
"$rollstep" view "$out/run" > /dev/null || { echo "FAIL: view of the older plan.csv"; exit 1; }
planOf "$out/run/replay.html" > "$out/plan_old"
cmp -s "$out/plan_gz" "$out/plan_old" ||
  { echo "FAIL: the page's plans from plan.csv differ from those of plan.csv.gz"; exit 1; }
cp "$out/run/replay.html" "$out/page_before"
# Each malformed file: refused with its message, the page untouched.
refused() {  # NAME REGEX: view fails on $out/run/plan.csv with a message matching REGEX
  err=$("$rollstep" view "$out/run" 2>&1 >/dev/null)
  rc=$?
  { [ $rc -ge 1 ] && [ $rc -le 123 ]; } || { echo "FAIL: $1: exit status $rc"; exit 1; }
  echo "$err" | grep -Eq "$2" || { echo "FAIL: $1: message: $err"; exit 1; }
  cmp -s "$out/page_before" "$out/run/replay.html" || { echo "FAIL: $1: the page changed"; exit 1; }
}
plan="$out/run/plan.csv"
sed '3s/,[^,]*$//' "$out/plan.csv" > "$plan"
refused "a short row" "plan '$plan': line 3: [0-9]+ fields, the header has [0-9]+"
sed '4s/^\([^,]*,[^,]*,[^,]*,[^,]*\),[^,]*,/\1,abc,/' "$out/plan.csv" > "$plan"
refused "a word for a number" "plan '$plan': base_x\[m\] is not a number in data row 3: 'abc'"
cut -d, -f1-3,5- "$out/plan.csv" > "$plan"
refused "no mode column" "plan '$plan': no column mode\[-\]"
awk -F, 'BEGIN { OFS = "," } { if (NF > 9) NF = NF - 1; print }' "$out/plan.csv" > "$plan"
refused "a contact without its z" "plan '$plan': column foot_.*_x\[m\] without foot_.*_z\[m\]"
{ head -n 1 "$out/plan.csv"; tail -n 1 "$out/plan.csv"; sed -n '2p' "$out/plan.csv"; } > "$plan"
refused "solutions out of order" "plan '$plan': solution_time\[s\] goes back in time in data row 2"
head -n 0 "$out/plan.csv" > "$plan"
refused "an empty file" "plan '$plan': empty"
echo "view old plan check passed"
