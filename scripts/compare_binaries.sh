#!/usr/bin/env bash
# Two builds of drive-sim on the same logged DRIVE run: wall time (hyperfine, alternating
# warm runs) and instructions (callgrind, repeatable whatever else the machine does), and
# whether the two logs are the same bytes. For a change that must cost no speed (a refactor,
# a crate split): build the commit before it and the commit after it in release mode, then
#
#   scripts/compare_binaries.sh BEFORE/target/release/drive-sim AFTER/target/release/drive-sim
#
# Needs hyperfine and valgrind (Debian packages). Run from the repository root, so that both
# binaries read the same robots/ and terrains/.
set -euo pipefail
before=${1:?usage: compare_binaries.sh BEFORE_BINARY AFTER_BINARY [STEPS]}
after=${2:?usage: compare_binaries.sh BEFORE_BINARY AFTER_BINARY [STEPS]}
steps=${3:-300}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
run() { echo "$1 run --robot warthog --terrain gravel --steps $2 --seed 1 --quiet --force --out $out/$3 --name r"; }

echo "== wall time, $steps-step Warthog DRIVE on gravel with MCAP logging"
hyperfine -N --warmup 1 --runs "${RUNS:-10}" -n before "$(run "$before" "$steps" before)" -n after "$(run "$after" "$steps" after)"
if cmp -s "$out/before/r.mcap" "$out/after/r.mcap"; then echo "logs: identical bytes"; else echo "logs: DIFFER"; fi

echo "== instructions (callgrind), 100 steps"
for side in before after; do
    bin=$before
    [ "$side" = after ] && bin=$after
    n=$(valgrind --tool=callgrind --callgrind-out-file="$out/callgrind_$side.out" $(run "$bin" 100 "cg_$side") 2>&1 \
        | sed -n 's/.*Collected : \([0-9]*\).*/\1/p')
    echo "$side: $n instructions"
    eval "n_$side=$n"
done
python3 -c "print(f'after / before: {$n_after / $n_before:.5f}')"
