#!/usr/bin/env bash
# Instructions per control cycle, counted by callgrind (repeatable whatever the machine is
# doing): a recorded log replayed through the cycle's compute path (`dima bench cycle`: decode
# with CRC, pairing, safety, controller, Maestro encode, log record), counting only inside
# `measured_cycles`. Usage, from the repository root:
#
#   bash bench/cycle-instructions.sh [LOG.mcap]   # without a log: records a 20 s `dima sim`
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v valgrind >/dev/null; then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq valgrind >/dev/null
fi
dima=${DIMA:-}
if [ -z "$dima" ]; then
  cargo build --release --locked -p dima
  dima=target/release/dima
fi
out=${OUT:-target/bench-cycle}
mkdir -p "$out"
log=${1:-}
if [ -z "$log" ]; then
  rm -rf "$out/sim"
  "$dima" sim --quiet --log-dir "$out/sim" >/dev/null
  log=$(ls "$out"/sim/*.mcap)
fi

valgrind --tool=callgrind --callgrind-out-file="$out/callgrind.out" \
  --toggle-collect='*measured_cycles*' "$dima" bench cycle "$log" --repeat 1 \
  >"$out/bench.txt" 2>"$out/valgrind.log"
cycles=$(sed -n 's/^\([0-9]*\) cycles.*/\1/p' "$out/bench.txt")
instructions=$(callgrind_annotate "$out/callgrind.out" 2>/dev/null \
  | sed -n 's/^ *\([0-9,]*\) .*PROGRAM TOTALS.*/\1/p' | tr -d ,)
echo "log: $log"
echo "cycles: $cycles, instructions in the compute path: $instructions"
echo "instructions per cycle: $((instructions / cycles))"
