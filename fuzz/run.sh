#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ and runs each one for at most RUNS executions and
# SECONDS seconds (docs/fuzzing.md).
#
#   fuzz/run.sh [RUNS] [SECONDS] [TARGET…]      defaults: 1000000 executions, 600 s, every target
#
# Needs cargo-fuzz (`cargo install cargo-fuzz`) and a compiler that accepts the `-Z` flags of the
# coverage instrumentation: the default toolchain with RUSTC_BOOTSTRAP=1 (set here), or the
# nightly one with FUZZ_TOOLCHAIN=nightly. FUZZ_TARGET_DIR (default fuzz/target) is where the
# instrumented build goes: a directory outside the clone lets fresh clones reuse it.
# Each target starts from seeds: the example configs and the adversarial fixtures (configs), the
# LAMMPS fixtures (data files), checkpoints of each protocol made here by short runs
# (checkpoints), and the regression inputs of crates/grainwave-experiments/tests/fuzz-regressions/.
# New inputs go to target/fuzz-corpus/<target>/ (not in the repository); a failing input is
# written to fuzz/artifacts/<target>/ and makes the script exit 1. Per target it prints the
# executions done and their rate.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
runs=${1:-1000000}
seconds=${2:-600}
shift $(( $# < 2 ? $# : 2 ))
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    targets=(config_simulation config_e1 config_e2 config_e3 checkpoint lammps_data)
fi
target_dir=${FUZZ_TARGET_DIR:-$root/fuzz/target}
# `cargo fuzz` with the chosen compiler (only the fuzz build: the seed build below is the normal one)
fuzz() {
    if [ "${FUZZ_TOOLCHAIN:-}" = nightly ]; then
        cargo +nightly fuzz "$@"
    else
        RUSTC_BOOTSTRAP=1 cargo fuzz "$@"
    fi
}
flags=(-O --codegen-units 4 --target-dir "$target_dir")
regressions=crates/grainwave-experiments/tests/fuzz-regressions
corpus=target/fuzz-corpus
seeds=target/fuzz-seeds
mkdir -p "$corpus" "$seeds/checkpoint" "$seeds/lammps"

# checkpoint seeds: one state of each protocol, from short runs of the current program
if [[ " ${targets[*]} " == *" checkpoint "* ]]; then
    cargo build --release -q -p grainwave-cli
    bin=target/release/grainwave
    tmp=$(mktemp -d)
    adv=crates/grainwave-cli/tests/adversarial
    sed 's/count = 400/count = 30/' "$adv/quick.toml" > "$tmp/small.toml"
    "$bin" --threads 1 --quiet run "$tmp/small.toml" --out "$tmp/simulation" >/dev/null
    "$bin" --threads 1 --quiet run "$adv/e1-step-limit.toml" --out "$tmp/e1" 2>/dev/null || true
    "$bin" --threads 1 --quiet run "$adv/e2-replay-blow-up.toml" --out "$tmp/e2" 2>/dev/null || true
    "$bin" --threads 1 --quiet run examples/e3-slab.toml --out "$tmp/e3" >/dev/null
    for p in simulation e1 e2 e3; do
        cp "$tmp/$p/checkpoint.gwck" "$seeds/checkpoint/$p.gwck"
    done
    cp "$tmp/e2/checkpoints/ck-000001.gwck" "$seeds/checkpoint/e2-strain.gwck"
    rm -rf "$tmp"
fi
cp crates/grainwave-io/tests/fixtures/lammps/*.data "$seeds/lammps/"

seed_dirs() {
    case $1 in
        config_*) echo examples examples/papers crates/grainwave-cli/tests/adversarial "$regressions/config" ;;
        checkpoint) echo "$seeds/checkpoint" "$regressions/checkpoint" ;;
        lammps_data) echo "$seeds/lammps" "$regressions/lammps" ;;
    esac
}

# one build for every target (they share the instrumented dependencies)
fuzz build "${flags[@]}"
status=0
for t in "${targets[@]}"; do
    mkdir -p "$corpus/$t" "fuzz/artifacts/$t"
    dirs=()
    for d in $(seed_dirs "$t"); do
        [ -d "$d" ] && dirs+=("$root/$d")
    done
    log=$root/target/fuzz-$t.log
    # -rss_limit_mb / -malloc_limit_mb: an input that makes the loader allocate more than 2 GiB
    # (at once or in total) is a failure; -timeout: one that takes more than 10 s is one too
    if fuzz run "${flags[@]}" "$t" "$root/$corpus/$t" "${dirs[@]}" -- \
        -runs="$runs" -max_total_time="$seconds" -rss_limit_mb=2048 -malloc_limit_mb=2048 -timeout=10 \
        -max_len=262144 -print_final_stats=1 >"$log" 2>&1; then
        result=ok
    else
        result="FAILED (see $log and fuzz/artifacts/$t/)"
        status=1
    fi
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
    rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
    echo "fuzz $t: $execs executions ($rate/s), $result"
done
exit $status
