#!/usr/bin/env bash
# Soak run of the station (outside ctest): N pairs through `flatscan station --source
# folder:...` (3 simulated paper-preset pairs, 2592 x 1944, delivered again and again under
# new ids, each pair hard-linked into a staging folder and renamed into the watched one, as
# a camera program would), the station's resident size sampled as it goes, then the
# record count checked against the pair count.
#   scripts/soak.sh [PAIRS=10000] [WORK=/tmp/flatscan-soak]
# Prints "committed rss_mb" samples, then the totals; exit 0 when every pair has exactly one
# record and every pair was measured, 1 otherwise.
set -euo pipefail
PAIRS=${1:-10000}
WORK=${2:-/tmp/flatscan-soak}
BIN="$(cd "$(dirname "$0")/.." && pwd)/build/flatscan"
rm -rf "$WORK" && mkdir -p "$WORK/in" "$WORK/staging"
"$BIN" simulate --preset paper --parts 3 --no-calibration --no-markers --seed 2 -q -o "$WORK/data" > /dev/null
cat > "$WORK/recipe.yml" <<YML
name: soak
thickness_mm: 0.2
tolerance_mm: 0.1
rig: data/rig.yml
plane: data/plane_true.yml
YML
"$BIN" station --recipe "$WORK/recipe.yml" --source "folder:$WORK/in" --store "$WORK/results.db" \
  --until-idle 20 -q 2> "$WORK/station.err" &
STATION=$!
trap 'kill $STATION 2>/dev/null || true' EXIT
( for ((i = 0; i < PAIRS; i++)); do
    k=$((i % 3))
    for side in left right; do
      ln "$WORK/data/parts/part_00${k}_${side}.png" "$WORK/staging/s${i}_${side}.png"
      mv "$WORK/staging/s${i}_${side}.png" "$WORK/in/s${i}_${side}.png"
    done
    # Deliver a little faster than the station measures, so that it is never idle for long.
    if (( i % 50 == 49 )); then sleep 1; fi
  done ) &
FEEDER=$!
echo "committed rss_mb"
while kill -0 $STATION 2>/dev/null; do
  rss=$(awk '/VmRSS/ {printf "%.1f", $2 / 1024}' /proc/$STATION/status 2>/dev/null || echo "")
  committed=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['committed'])" "$WORK/results.status.json" 2>/dev/null || echo 0)
  [ -n "$rss" ] && echo "$committed $rss"
  sleep 15
done
wait $FEEDER || true
wait $STATION && rc=0 || rc=$?
records=$("$BIN" results --store "$WORK/results.db" --csv | tail -n +2 | wc -l)
ids=$("$BIN" results --store "$WORK/results.db" --csv | tail -n +2 | cut -d, -f3 | sort -u | wc -l)
measured=$("$BIN" results --store "$WORK/results.db" --csv | tail -n +2 | cut -d, -f5 | grep -c true || true)
echo "station exit $rc; pairs $PAIRS; records $records; distinct ids $ids; measured $measured"
[ "$rc" -eq 0 ] && [ "$records" -eq "$PAIRS" ] && [ "$ids" -eq "$PAIRS" ] && [ "$measured" -eq "$PAIRS" ]
