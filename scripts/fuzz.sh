#!/usr/bin/env bash
# Fuzzes each target (fuzz/*_fuzz.cc) with libFuzzer for SECONDS (default 60) of wall
# time, with AddressSanitizer and UBSan, starting from and adding to its corpus in
# fuzz/corpus/<target>/ (the inputs ctest replays). A crash leaves crash-* in
# build-fuzz/findings/<target>/ and stops that target.
#   scripts/fuzz.sh [SECONDS] [TARGET...]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
seconds="${1:-60}"; shift || true
CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFLATSCAN_FUZZ=ON \
  -DFLATSCAN_SANITIZE=ON -DFLATSCAN_BUILD_TESTS=OFF -DFLATSCAN_BUILD_BENCHMARKS=OFF > /dev/null
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=($(ls fuzz/*_fuzz.cc | xargs -n1 basename | sed 's/_fuzz\.cc$//'))
cmake --build build-fuzz -j "$(nproc)" --target $(printf '%s_fuzz ' "${targets[@]}")
for t in "${targets[@]}"; do
  mkdir -p "fuzz/corpus/$t" "build-fuzz/findings/$t"
  echo "fuzz: $t for $seconds s"
  # One allocation above 1 GB is a finding (the product's bound); the process as a whole
  # may hold more, for ASan's shadow and quarantine.
  ASAN_OPTIONS=detect_leaks=1:quarantine_size_mb=16 build-fuzz/fuzz/${t}_fuzz -max_total_time="$seconds" \
    -malloc_limit_mb=1024 -rss_limit_mb=3072 -timeout=10 -artifact_prefix="build-fuzz/findings/$t/" \
    -print_final_stats=1 "fuzz/corpus/$t" 2>&1 |
    grep -E "^(stat::number_of_executed_units|stat::peak_rss_mb|==[0-9]+==ERROR|SUMMARY|Done)" || true
done
