#!/usr/bin/env bash
# Only crates/log reads MCAP: every other file uses dima-log's bounded reader (dima_log::reader,
# dima_log::run). Files that write bytes by hand from the specification are not reading.
# Exits 1 naming each file that calls one of the `mcap` crate's readers directly.
set -euo pipefail
cd "$(dirname "$0")/.."
pattern='mcap::(MessageStream|Summary::read|read::|sans_io|parse_record|records::Record|LinearReader|read_summary)|mcap::read\b|use mcap::(read|sans_io|MessageStream|Summary)'
offenders=$(git ls-files '*.rs' | grep -v '^crates/log/' | xargs grep -lE "$pattern" || true)
if [ -n "$offenders" ]; then
    echo "MCAP read outside crates/log (use dima_log::reader or dima_log::run):"
    for f in $offenders; do
        grep -nE "$pattern" "$f" | sed "s|^|  $f:|"
    done
    exit 1
fi
echo "mcap readers: only crates/log"
