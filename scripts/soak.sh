#!/usr/bin/env bash
# Soak: the whole application against the simulation for M minutes with random faults, and its
# memory watched from the outside.
#
#   scripts/soak.sh --minutes M [--seed N] [--config FILE]
#
# Builds `dima` (release), runs `dima sim --scenario soak --random-faults` for M minutes (fault
# windows drawn from the seed, the scripted ground station revives after each one), samples
# the process's resident memory every SOAK_SAMPLE_S seconds (default 10): VmRSS, everything
# resident, and RssAnon, the memory the process allocated itself (heap, stacks, buffers), both
# from /proc/PID/status. VmRSS also counts pages of the executable and its libraries read in
# the first time a code path runs (an error path after a fault, say): shared, clean, bounded by
# the files' size, and in a debug build about a megabyte at the first device reopen. So the
# limit applies to RssAnon; both growths are printed. "Start" is the first sample after
# SOAK_WARMUP_S seconds (default 30: the loop -> logger ring is allocated at start-up, but without
# `--realtime` (mlockall) its pages are touched only during its first lap, log_ring_records /
# loop rate = 4096 / 250 Hz = 16 s), "end" the last sample before the run's end (the read-back
# of the log afterwards is not the robot's). Exit status 0 only when nothing crashed (exit
# status and a log check) and RssAnon grew by at most SOAK_MAX_GROWTH_KIB (1024). Whether every
# expectation of the scenario held (after every fault window the car drives again) is
# printed beside the missed periods: on a loaded machine an overrunning loop keeps the robot
# in FAILSAFE (revives refused while it overruns), which is the robot being right.
# --config FILE runs the application with that configuration (`dima sim --config`), e.g. a
# `[log] max_file_duration_s = 60` to see the log split within a short soak. The run's log
# files (`NAME.mcap`, `NAME-1.mcap`, ...) are counted and each must read back.
#
# Environment: DIMA (a prebuilt binary: skips the build), OUT (keep the run's files there;
# default a temporary directory, removed on success).
set -euo pipefail
cd "$(dirname "$0")/.."

usage() { echo "usage: $0 --minutes M [--seed N] [--config FILE]" >&2; exit 2; }
minutes=""
seed=1
config_args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --minutes) minutes="${2:-}"; shift 2 || usage ;;
    --seed) seed="${2:-}"; shift 2 || usage ;;
    --config) [ -n "${2:-}" ] || usage; config_args=(--config "$2"); shift 2 ;;
    -h|--help) sed -n '2,28p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) usage ;;
  esac
done
[[ "$minutes" =~ ^[0-9]+([.][0-9]+)?$ ]] || usage
[[ "$seed" =~ ^[0-9]+$ ]] || usage
sample_s="${SOAK_SAMPLE_S:-10}"
warmup_s="${SOAK_WARMUP_S:-30}"
max_growth_kib="${SOAK_MAX_GROWTH_KIB:-1024}"
duration_s=$(awk -v m="$minutes" 'BEGIN { printf "%.0f", m * 60 }')
[ "$duration_s" -ge $((warmup_s + 2 * sample_s)) ] \
  || { echo "soak: at least $((warmup_s + 2 * sample_s)) s (warm-up and two samples)" >&2; exit 2; }

if [ -z "${DIMA:-}" ]; then
  echo "soak: building dima (release)"
  cargo build --release --locked -q -p dima
  DIMA=target/release/dima
fi

keep_out=1
if [ -z "${OUT:-}" ]; then
  OUT=$(mktemp -d)
  keep_out=0
fi
mkdir -p "$OUT"
stdout="$OUT/sim.out"
stderr="$OUT/sim.err"
samples="$OUT/rss.tsv"
echo "soak: $minutes min, seed $seed, files in $OUT"

"$DIMA" sim --scenario soak --random-faults --duration "$duration_s" --seed "$seed" --quiet \
  --log-dir "$OUT/logs" "${config_args[@]}" >"$stdout" 2>"$stderr" &
pid=$!
t0=$SECONDS
printf 't_s\trss_kib\tanon_kib\n' >"$samples"
while kill -0 "$pid" 2>/dev/null; do
  t=$((SECONDS - t0))
  # Only samples inside the run: after --duration the simulation reads its log back.
  if [ "$t" -le $((duration_s - 2)) ]; then
    mem=$(awk '/^VmRSS:/ { r = $2 } /^RssAnon:/ { a = $2 } END { if (r && a) print r "\t" a }' \
      "/proc/$pid/status" 2>/dev/null || true)
    [ -n "$mem" ] && printf '%s\t%s\n' "$t" "$mem" >>"$samples"
  fi
  # Sleep in short steps, so the end of the run is seen at once.
  for _ in $(seq $((sample_s * 10))); do
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.1
  done
done
set +e
wait "$pid"
status=$?
set -e

# Crashes: the exit status (0 passed, 1 an expectation failed; anything else is an error or a
# signal) and the log (a panic, or a log that cannot be read back).
crashes=0
crash_reasons=()
if [ "$status" -ne 0 ] && [ "$status" -ne 1 ]; then
  crashes=$((crashes + 1))
  crash_reasons+=("exit status $status")
fi
if grep -q "panicked" "$stderr"; then
  crashes=$((crashes + 1))
  crash_reasons+=("a panic in the log: $(grep -m1 panicked "$stderr")")
fi
mcap_log=$(sed -n 's/^MCAP log: \(.*\) (open it in Foxglove Studio)$/\1/p' "$stdout" | tail -1)
if [ -z "$mcap_log" ] || ! "$DIMA" log info "$mcap_log" >"$OUT/log-info.txt" 2>&1; then
  crashes=$((crashes + 1))
  crash_reasons+=("no readable MCAP log (${mcap_log:-none named})")
fi
# Every file of the run (split by duration or resumed after a disk fault) reads back.
log_files=0
first_log=$(find "$OUT/logs" -maxdepth 1 -name 'dima-*.mcap' ! -name 'dima-*-*.mcap' | sort | head -1)
if [ -n "$first_log" ]; then
  stem="${first_log%.mcap}"
  n=0
  f="$first_log"
  while [ -f "$f" ]; do
    log_files=$((log_files + 1))
    if ! "$DIMA" log info "$f" >"$OUT/log-info-$n.txt" 2>&1; then
      crashes=$((crashes + 1))
      crash_reasons+=("unreadable MCAP log $f")
    fi
    n=$((n + 1))
    f="$stem-$n.mcap"
  done
fi

soak_line=$(grep '^soak: ' "$stdout" | tail -1 || true)
field() { sed -n "s/.* \([0-9][0-9]*\) $1.*/\1/p" <<<"$soak_line"; }
missed=$(field "missed periods")
windows=$(sed -n 's/^soak: \([0-9][0-9]*\) fault windows.*/\1/p' <<<"$soak_line")
failsafes=$(field "failsafe(s)")
revives=$(field "revive(s)")
cycles=$(field "cycles")
dropped=$(field "log records dropped")

# Column COL (2: VmRSS, 3: RssAnon) of the first sample after the warm-up, of the last, and its
# largest value.
first_after_warmup() { awk -F'\t' -v w="$warmup_s" -v c="$1" 'NR > 1 && $1 >= w { print $c; exit }' "$samples"; }
last_sample() { awk -F'\t' -v c="$1" 'NR > 1 { v = $c } END { print v }' "$samples"; }
largest() { awk -F'\t' -v c="$1" 'NR > 1 && $c > m { m = $c } END { print m + 0 }' "$samples"; }
rss_start=$(first_after_warmup 2)
rss_end=$(last_sample 2)
rss_max=$(largest 2)
anon_start=$(first_after_warmup 3)
anon_end=$(last_sample 3)
anon_max=$(largest 3)
n_samples=$(($(wc -l <"$samples") - 1))
rss_growth=""
growth=""
if [ -n "$rss_start" ] && [ -n "$rss_end" ]; then
  rss_growth=$((rss_end - rss_start))
  growth=$((anon_end - anon_start))
fi

checks="held"
[ "$status" -eq 0 ] || checks="$(grep -c '^  FAIL ' "$stdout" || true) of $(grep -cE '^  (ok  |FAIL|skip) ' "$stdout" || true) failed, first: $(grep -m1 '^FAIL: ' "$stdout" || echo "exit status $status")"

echo
echo "=== soak summary"
echo "minutes:            $minutes (seed $seed)"
echo "cycles:             ${cycles:-?} (${missed:-?} periods missed)"
echo "fault windows:      ${windows:-?}"
echo "failsafes:          ${failsafes:-?}"
echo "revives:            ${revives:-?}"
echo "log records dropped: ${dropped:-?}"
echo "log files:          $log_files"
echo "crashes:            $crashes${crash_reasons[*]:+ (${crash_reasons[*]})}"
echo "checks:             $checks"
echo "RSS start/end:      ${rss_start:-?} / ${rss_end:-?} KiB (VmRSS; first sample after ${warmup_s} s, max ${rss_max} KiB)"
echo "RSS growth:         ${rss_growth:-?} KiB (everything resident, code paged in included)"
echo "anon start/end:     ${anon_start:-?} / ${anon_end:-?} KiB (RssAnon; max ${anon_max} KiB)"
echo "anon growth:        ${growth:-?} KiB (limit $max_growth_kib; $n_samples samples every ${sample_s} s in $samples)"

failed=0
[ "$crashes" -eq 0 ] || failed=1
if [ -z "$growth" ]; then
  echo "soak: too few RSS samples" >&2
  failed=1
elif [ "$growth" -gt "$max_growth_kib" ]; then
  echo "soak: anonymous memory (RssAnon) grew by $growth KiB (more than $max_growth_kib)" >&2
  failed=1
fi
if [ "$failed" -eq 0 ]; then
  echo "soak: PASS"
  [ "$keep_out" -eq 1 ] || rm -rf "$OUT"
else
  echo "soak: FAIL (files kept in $OUT)"
  tail -20 "$stderr" >&2
fi
exit "$failed"
