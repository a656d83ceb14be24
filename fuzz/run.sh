#!/usr/bin/env bash
# A bounded fuzz run of every target (libFuzzer via cargo-fuzz, nightly):
#   fuzz/run.sh [SECONDS per target, default 60] [TARGET…]
# Needs: rustup toolchain nightly, `cargo install cargo-fuzz`, a C++ compiler.
# The build goes to $HOME/.cache/coapt-fuzz-target and the growing corpus to
# $HOME/.cache/coapt-fuzz-corpus/<target> (outside the clone: thousands of
# files); the committed seeds, small valid files of each format, are in
# fuzz/seeds/<target>. A crash, leak, timeout or out-of-memory input is saved in
# fuzz/artifacts/<target>/ (slow-unit-* files only report slowness) and must
# become a regression test (tests/it/bad_input.rs, or a unit test of the reader).
set -euo pipefail
cd "$(dirname "$0")/.."
secs=${1:-60}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(volume dicom vtp markups configs valve_json stages)
dir=${COAPT_FUZZ_TARGET_DIR:-$HOME/.cache/coapt-fuzz-target}
cargo +nightly fuzz build -O --target-dir "$dir"
corpus=${COAPT_FUZZ_CORPUS:-$HOME/.cache/coapt-fuzz-corpus}
# Run the built binaries themselves: `cargo fuzz run` builds again with
# other flags (debug line tables), a second full sanitizer build.
bin="$dir/x86_64-unknown-linux-gnu/release"
for t in "${targets[@]}"; do
  mkdir -p "$corpus/$t" "fuzz/artifacts/$t"
  echo "== $t: ${secs} s"
  # A stage runs a whole computation: its first input also builds the case.
  timeout=10
  [ "$t" = stages ] && timeout=60
  "$bin/$t" -artifact_prefix="fuzz/artifacts/$t/" -max_total_time="$secs" -rss_limit_mb=2048 \
    -malloc_limit_mb=1024 -timeout=$timeout -report_slow_units=$timeout -print_final_stats=1 \
    "$corpus/$t" "fuzz/seeds/$t" 2>&1 |
    grep -E "^(stat::|#[0-9]+ *DONE|==|SUMMARY|ERROR|artifact_prefix|Test unit written|INFO: Seed|thread .* panicked)" || true
done
if compgen -G "fuzz/artifacts/*/[!s]*" >/dev/null; then
  echo "crashes saved (each must become a regression test):" fuzz/artifacts/*/[!s]*
  exit 1
fi
