#!/usr/bin/env bash
# Wake-up latency of the DIMA loop skeleton (`dima bench wakeup`) beside cyclictest, in the same
# run on the same machine, as ratios per percentile. Usage (as root, from the repository root):
#
#   bash bench/wakeup-vs-cyclictest.sh            # 20 s per run
#   DURATION=60 bash bench/wakeup-vs-cyclictest.sh
#   DIMA=target/debug/dima DURATION=1 bash bench/wakeup-vs-cyclictest.sh   # a quick check
#
# For each of 250 Hz and 1 kHz, three repeats with both threads on the same CPU (their wake-ups
# interleave: cyclictest at each whole second, dima half a period later), then one run each
# with the two on different CPUs, in both orders. Prints n, p50, p99, p99.9, max and missed
# periods for both, and dima/cyclictest per percentile.
set -euo pipefail
cd "$(dirname "$0")/.."

duration=${DURATION:-20}
priority=${PRIORITY:-80}
out=${OUT:-target/bench-wakeup}
mkdir -p "$out"

if ! command -v cyclictest >/dev/null; then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq rt-tests >/dev/null
fi
# DIMA=path uses a binary already built (CI passes its debug build).
dima=${DIMA:-}
if [ -z "$dima" ]; then
  cargo build --release --locked -p dima
  dima=target/release/dima
fi
cpus=$(nproc)
last_cpu=$((cpus - 1))

# run NAME INTERVAL_US DIMA_CPU CYCLICTEST_CPU
run() {
  local name=$1 interval=$2 dcpu=$3 ccpu=$4
  "$dima" bench wakeup --interval-us "$interval" --duration "$duration" --priority "$priority" \
    --cpu "$dcpu" --histfile "$out/$name.dima.hist" 2>"$out/$name.dima.log" &
  local pid=$!
  cyclictest -p "$priority" -a "$ccpu" -i "$interval" -m -q -h 5000 --secaligned 0 \
    -D "$((${duration%.*} + 1))" >"$out/$name.cyclictest.hist" 2>"$out/$name.cyclictest.log"
  wait "$pid"
}

for interval in 4000 1000; do
  for rep in 1 2 3; do
    run "i${interval}-same-cpu${last_cpu}-r${rep}" "$interval" "$last_cpu" "$last_cpu"
  done
  if [ "$cpus" -ge 2 ]; then
    run "i${interval}-dima-cpu0-cyclictest-cpu1" "$interval" 0 1
    run "i${interval}-dima-cpu1-cyclictest-cpu0" "$interval" 1 0
  fi
done

python3 bench/histogram-ratios.py "$out"/*.dima.hist
