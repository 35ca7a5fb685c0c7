#!/usr/bin/env bash
# Set-up and run entry point used by the README and by CI.
#   scripts/dev.sh demo      install, build (Release) and run `flatscan demo`
#   scripts/dev.sh test      install, build (Release) and run every test under ctest
#   scripts/dev.sh sanitize  install, build with ASan+UBSan into build-asan and run the tests
#   scripts/dev.sh build     install and build only
set -euo pipefail
cd "$(dirname "$0")/.."
mode="${1:-test}"
bash scripts/install-deps.sh
jobs="$(nproc)"
configure_and_build() {  # dir, extra cmake args...
  local dir="$1"; shift
  cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@"
  cmake --build "$dir" -j "$jobs"
}
# Runs the sanitizer build's tests. LeakSanitizer's leak check at exit can crash on its own
# ("Tracer caught signal 11 ... LeakSanitizer has encountered a fatal error", google/sanitizers
# #1353) after a test has passed; main() joins the worker threads to avoid it
# (src/flatscan/util/worker_threads.h). A test whose run shows that crash after "[  PASSED  ]"
# and no "[  FAILED  ]" is run once more, alone; any other failure fails at once.
run_sanitized_tests() {
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  if ctest --test-dir build-asan --output-on-failure -j "$jobs"; then return 0; fi
  local tmp=build-asan/Testing/Temporary name
  cp "$tmp/LastTest.log" build-asan/first-run.log
  while IFS=: read -r _ name; do
    if ! scripts/lsan-tracer-crash-only.awk -v test="$name" build-asan/first-run.log; then
      echo "sanitize: $name failed (not only LeakSanitizer's tracer crash): no retry" >&2
      return 1
    fi
    echo "sanitize: $name passed, then LeakSanitizer's tracer crashed at exit: running it again alone" >&2
  done < "$tmp/LastTestsFailed.log"
  ctest --test-dir build-asan --output-on-failure --rerun-failed
}
case "$mode" in
  demo)
    configure_and_build build
    build/flatscan demo ;;
  test)
    configure_and_build build
    ctest --test-dir build --output-on-failure -j "$jobs" ;;
  sanitize)
    configure_and_build build-asan -DFLATSCAN_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo
    run_sanitized_tests ;;
  build)
    configure_and_build build ;;
  *) echo "usage: scripts/dev.sh demo|test|sanitize|build" >&2; exit 2 ;;
esac
