#!/usr/bin/env bash
# Fuzzes one target for SECONDS, starting from its committed seeds (fuzz/seeds/TARGET) and the
# corpus it has grown so far (fuzz/corpus/TARGET). Exits non-zero on any crash, timeout or
# out-of-memory (the input is saved in fuzz/artifacts/TARGET/); prints the number of runs.
#
#   fuzz/run.sh TARGET SECONDS [libFuzzer options...]
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -lt 2 ]; then
  echo "usage: fuzz/run.sh TARGET SECONDS [libFuzzer options...]" >&2
  exit 2
fi
target=$1
seconds=$2
shift 2
# shellcheck source=fuzz/env.sh
. fuzz/env.sh
[ -n "${FUZZ_TC:-}" ] || fuzz_setup

corpus=fuzz/corpus/$target
mkdir -p "$corpus" fuzz/logs
log=fuzz/logs/$target.log
status=0
cargo "+$FUZZ_TC" fuzz run "${FUZZ_FLAGS[@]}" "$target" "$corpus" "fuzz/seeds/$target" -- \
  "${FUZZ_LIMITS[@]}" -max_total_time="$seconds" "$@" >"$log" 2>&1 || status=$?
execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
files=$(find "$corpus" -type f | wc -l)
bytes=$(du -sb "$corpus" | cut -f1)
if [ "$status" -ne 0 ]; then
  # The end of libFuzzer's report, without the failing input's (long) Debug dump.
  grep -v '^\s*\[' "$log" | tail -n 40 | cut -c1-240 >&2
  echo "$target: FAILED (exit $status) after ${execs:-?} runs; log $log, inputs in fuzz/artifacts/$target/" >&2
  exit 1
fi
printf '%-16s %12s runs in %ss, corpus %d files, %d bytes\n' "$target" "${execs:-?}" "$seconds" "$files" "$bytes"
