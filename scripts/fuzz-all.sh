#!/usr/bin/env bash
# Fuzzes every cargo-fuzz target in fuzz/ for SECONDS each, from its seeds: installs what is
# missing (nightly, or stable with RUSTC_BOOTSTRAP=1; cargo-fuzz), builds all targets once,
# then runs them one after the other. Fails on any crash, timeout or out-of-memory, after
# running the rest; prints the runs of each target.
#
#   scripts/fuzz-all.sh SECONDS
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -ne 1 ]; then
  echo "usage: scripts/fuzz-all.sh SECONDS" >&2
  exit 2
fi
seconds=$1
# shellcheck source=fuzz/env.sh
. fuzz/env.sh
fuzz_setup
export FUZZ_TC
echo "fuzz: toolchain $FUZZ_TC ($(rustup run "$FUZZ_TC" rustc --version))${RUSTC_BOOTSTRAP:+, RUSTC_BOOTSTRAP=1}"
cargo "+$FUZZ_TC" fuzz build "${FUZZ_FLAGS[@]}"
failed=()
for target in $(cargo "+$FUZZ_TC" fuzz list "${FUZZ_FLAGS[@]}"); do
  bash fuzz/run.sh "$target" "$seconds" || failed+=("$target")
done
if [ "${#failed[@]}" -gt 0 ]; then
  echo "fuzz: failed: ${failed[*]}" >&2
  exit 1
fi
