# Sourced by fuzz/run.sh and scripts/fuzz-all.sh: makes sure cargo-fuzz and a toolchain that
# accepts its sanitizer flags are there, and sets FUZZ_TC (the toolchain).
#
# The toolchain is nightly (installed with rustup if missing). If rustup cannot fetch nightly,
# stable is used with RUSTC_BOOTSTRAP=1, which lets it accept the -Z flags cargo-fuzz passes.
# FUZZ_TOOLCHAIN=stable (or any installed toolchain) skips the nightly step.

fuzz_setup() {
  if [ -n "${FUZZ_TOOLCHAIN:-}" ]; then
    FUZZ_TC=$FUZZ_TOOLCHAIN
  elif rustup run nightly rustc --version >/dev/null 2>&1; then
    FUZZ_TC=nightly
  elif rustup toolchain install nightly --profile minimal >&2; then
    FUZZ_TC=nightly
  else
    echo "fuzz: rustup could not install nightly; using stable with RUSTC_BOOTSTRAP=1" >&2
    FUZZ_TC=stable
  fi
  if ! rustup run "$FUZZ_TC" rustc --version | grep -q nightly; then
    export RUSTC_BOOTSTRAP=1
  fi
  if ! command -v cargo-fuzz >/dev/null 2>&1; then
    echo "fuzz: installing cargo-fuzz" >&2
    cargo install cargo-fuzz --locked >&2
  fi
}

# cargo-fuzz's default build: release, with debug assertions and overflow checks, and
# AddressSanitizer. The same flags for `build` and `run`, so `run` never rebuilds.
FUZZ_FLAGS=(--fuzz-dir fuzz)

# libFuzzer's limits for every run: an input that takes longer than 10 s is a hang, one that
# allocates more than 256 MB at once or grows the process beyond 1 GB is an out-of-memory.
FUZZ_LIMITS=(-timeout=10 -rss_limit_mb=1024 -malloc_limit_mb=256 -print_final_stats=1)
