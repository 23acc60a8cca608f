#!/usr/bin/env bash
# Coverage-guided fuzzing of plsr's parsers with libFuzzer (docs/fuzzing.md).
#
#   bash scripts/fuzz.sh build                    builds every target
#   bash scripts/fuzz.sh list                     names the targets
#   bash scripts/fuzz.sh run TARGET [-- ARGS]     fuzzes one target (libFuzzer ARGS)
#   bash scripts/fuzz.sh all SECONDS              fuzzes every target for SECONDS
#                                                 each and prints a table of
#                                                 coverage and executions
#
# The targets are fuzz/fuzz_targets/*.rs, built as `cargo fuzz` builds them
# (SanitizerCoverage with inline 8-bit counters, PC tables and comparison
# tracing; debug assertions and overflow checks) but without installing
# cargo-fuzz: the flags are given to cargo here, and RUSTC_BOOTSTRAP=1 lets
# the stable toolchain accept them. Inputs start from the seeds committed in
# fuzz/seeds/TARGET and grow in target/fuzz/corpus/TARGET; a crash is
# written to target/fuzz/artifacts/TARGET/ and the run fails. A crash
# becomes a regression test by copying its input into fuzz/regressions/TARGET/
# (`make test` replays those files) once it is fixed.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
FUZZ="$ROOT/fuzz"
TARGET_DIR="$ROOT/target/fuzz"
TRIPLE="$(rustc -vV | sed -n 's/^host: //p')"
BIN="$TARGET_DIR/$TRIPLE/release"
# Each input may allocate at most this much; a reader that sizes a buffer
# from a header before checking it is found here.
MALLOC_LIMIT_MB="${PLSR_FUZZ_MALLOC_LIMIT_MB:-2048}"
# A single input running longer than this is a hang.
TIMEOUT_S="${PLSR_FUZZ_TIMEOUT:-20}"
# Largest input libFuzzer makes (seeds may be larger).
MAX_LEN="${PLSR_FUZZ_MAX_LEN:-16384}"
# More libFuzzer arguments for every run (`make test` gives -seed=1).
read -r -a EXTRA_ARGS <<< "${PLSR_FUZZ_ARGS:-}"

targets() {
    for f in "$FUZZ"/fuzz_targets/*.rs; do basename "$f" .rs; done
}

build() {
    # The flags go to the targets' crates only (`--target`), not to build
    # scripts and proc macros, as cargo-fuzz does it.
    RUSTC_BOOTSTRAP=1 \
    RUSTFLAGS="${RUSTFLAGS:-} -Cpasses=sancov-module \
        -Cllvm-args=-sanitizer-coverage-level=4 \
        -Cllvm-args=-sanitizer-coverage-inline-8bit-counters \
        -Cllvm-args=-sanitizer-coverage-pc-table \
        -Cllvm-args=-sanitizer-coverage-trace-compares \
        --cfg fuzzing" \
    cargo build --release --manifest-path "$FUZZ/Cargo.toml" \
        --target "$TRIPLE" --target-dir "$TARGET_DIR" --bins "$@"
}

# run TARGET SECONDS [libFuzzer args...]: fuzzes TARGET; its last lines of
# libFuzzer output are kept in target/fuzz/logs/TARGET.log.
run_target() {
    local target="$1" seconds="$2"
    shift 2
    local corpus="$TARGET_DIR/corpus/$target" artifacts="$TARGET_DIR/artifacts/$target"
    mkdir -p "$corpus" "$artifacts" "$TARGET_DIR/logs"
    local seeds=()
    [ -d "$FUZZ/seeds/$target" ] && seeds+=("$FUZZ/seeds/$target")
    [ -d "$FUZZ/regressions/$target" ] && seeds+=("$FUZZ/regressions/$target")
    local time_args=()
    [ "$seconds" != 0 ] && time_args+=("-max_total_time=$seconds")
    "$BIN/$target" "$corpus" "${seeds[@]}" \
        "-artifact_prefix=$artifacts/" \
        "-malloc_limit_mb=$MALLOC_LIMIT_MB" "-rss_limit_mb=$((MALLOC_LIMIT_MB * 2))" \
        "-timeout=$TIMEOUT_S" "-max_len=$MAX_LEN" \
        -print_final_stats=1 "${time_args[@]}" "${EXTRA_ARGS[@]}" "$@" \
        2> >(tee "$TARGET_DIR/logs/$target.log" >&2)
}

# The figures of a finished run, from its log: coverage (edges), features,
# corpus size, executions and executions per second.
summary_line() {
    local target="$1" log="$TARGET_DIR/logs/$1.log"
    local cov ft corp execs rate
    cov=$(grep -oE 'cov: [0-9]+' "$log" | tail -1 | cut -d' ' -f2)
    ft=$(grep -oE 'ft: [0-9]+' "$log" | tail -1 | cut -d' ' -f2)
    corp=$(grep -oE 'corp: [0-9]+' "$log" | tail -1 | cut -d' ' -f2)
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
    rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
    printf '%-20s %8s %8s %7s %10s %8s\n' "$target" "${cov:-?}" "${ft:-?}" "${corp:-?}" "${execs:-?}" "${rate:-?}"
}

case "${1:-}" in
    build)
        shift
        build "$@"
        ;;
    list)
        targets
        ;;
    run)
        target="${2:?usage: fuzz.sh run TARGET [-- libFuzzer args]}"
        shift 2
        [ "${1:-}" = "--" ] && shift
        build --bin "$target"
        run_target "$target" 0 "$@"
        ;;
    all)
        seconds="${2:?usage: fuzz.sh all SECONDS}"
        build
        failed=()
        for t in $(targets); do
            echo "== $t: $seconds s" >&2
            run_target "$t" "$seconds" >/dev/null 2>&1 || failed+=("$t")
        done
        printf '%-20s %8s %8s %7s %10s %8s\n' target edges features corpus executions "exec/s"
        for t in $(targets); do summary_line "$t"; done
        if [ "${#failed[@]}" -gt 0 ]; then
            for t in "${failed[@]}"; do
                echo "fuzz target $t failed; its log: target/fuzz/logs/$t.log" >&2
                tail -30 "$TARGET_DIR/logs/$t.log" >&2
            done
            exit 1
        fi
        ;;
    *)
        sed -n '2,20p' "$0" | sed 's/^# \{0,1\}//'
        exit 2
        ;;
esac
