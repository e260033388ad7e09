#!/usr/bin/env bash
# The fastest loop rate the whole system holds in simulation (serial links paced at their baud
# rates), next to cyclictest at the same rate in the same run. For each rate and sensor-link
# baud rate: `dima sim --scenario manual` for DURATION seconds with cyclictest beside it on the
# same CPUs; prints missed periods (%), packets ok (%), request-to-packet p50/p99 and the wire
# time, and cyclictest's p50/p99 at that interval. Usage, as root from the repository root:
#
#   bash bench/fastest-loop.sh                 # 60 s per run
#   DURATION=10 bash bench/fastest-loop.sh
set -euo pipefail
cd "$(dirname "$0")/.."

duration=${DURATION:-60}
out=${OUT:-target/bench-fastest}
mkdir -p "$out"
if ! command -v cyclictest >/dev/null; then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq rt-tests >/dev/null
fi
dima=${DIMA:-}
if [ -z "$dima" ]; then
  cargo build --release --locked -p dima
  dima=target/release/dima
fi

printf '%-6s %-8s %-9s %-8s %-8s %-20s %-18s %-18s %s\n' rate baud missed% ok% wire_us \
  "req->packet p50/p99" "dima wake p50/p99" "cyclictest p50/p99" scenario
for combo in 250:460800 500:921600 500:2000000 1000:2000000 2000:2000000; do
  rate=${combo%%:*} baud=${combo##*:}
  name="r${rate}-b${baud}"
  cfg="$out/$name.toml"
  # A shorter servo write budget above 250 Hz (the Maestro frame is 12 bytes).
  budget=$([ "$rate" -gt 250 ] && echo 200 || echo 300)
  # The loop on the last CPU (the robot's config isolates one with isolcpus).
  printf '[sensor]\nbaud = %s\n\n[maestro]\nwrite_budget_us = %s\n\n[realtime]\ncpus = [%s]\n' \
    "$baud" "$budget" "$(($(nproc) - 1))" >"$cfg"
  rm -rf "$out/$name"
  period_us=$((1000000 / rate))
  cyclictest -p 80 -i "$period_us" -m -q -h 5000 -D "$duration" >"$out/$name.cyclictest.hist" 2>&1 &
  cpid=$!
  if ! "$dima" sim --scenario manual --duration "$duration" --loop-rate "$rate" --config "$cfg" \
    --realtime --quiet --log-dir "$out/$name" >"$out/$name.sim.txt" 2>&1; then
    :
  fi
  wait "$cpid" || true
  wire=$((132 * 11 * 1000000 / baud))
  log=$(ls "$out/$name"/*.mcap 2>/dev/null | head -1 || true)
  cyc=$(python3 bench/histogram-ratios.py --p50-p99 "$out/$name.cyclictest.hist")
  if [ -z "$log" ]; then
    reason=$(grep -m1 -E "config|error" "$out/$name.sim.txt" | cut -c1-120)
    printf '%-6s %-8s %-9s %-8s %-8s %s\n' "$rate" "$baud" "-" "-" "$wire" "not run: $reason"
    continue
  fi
  info=$("$dima" log info "$log")
  cycles=$(sed -n 's/.*| \([0-9]*\) cycles |.*/\1/p' <<<"$info")
  missed=$(sed -n 's/.*missed periods \([0-9]*\).*/\1/p' <<<"$info")
  ok=$(sed -n 's/^packets: ok \([0-9]*\).*/\1/p' <<<"$info")
  rtp=$(sed -n 's/.*request->packet *n [0-9]* | p50 \([0-9]*\) p99 \([0-9]*\).*/\1\/\2/p' <<<"$info")
  wake=$(sed -n 's/.*wake latency *n [0-9]* | p50 \([0-9]*\) p99 \([0-9]*\).*/\1\/\2/p' <<<"$info")
  verdict=$(grep -m1 -oE '^(PASS|FAIL)' "$out/$name.sim.txt" || echo "?")
  printf '%-6s %-8s %-9s %-8s %-8s %-20s %-18s %-18s %s\n' "$rate" "$baud" \
    "$(awk -v m="$missed" -v c="$cycles" 'BEGIN{printf "%.3f", 100*m/(m+c)}')" \
    "$(awk -v o="$ok" -v c="$cycles" 'BEGIN{printf "%.2f", 100*o/c}')" "$wire" "$rtp" "$wake" "$cyc" \
    "$verdict"
done
