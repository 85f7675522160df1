#!/usr/bin/env bash
# Builds tests/consumer as a separate project against the module and checks its image.
#   run_consumer_test.sh installed  MAIN_BUILD_DIR WORK_DIR   (cmake --install into a temp prefix)
#   run_consumer_test.sh subdir     REPO_DIR       WORK_DIR   (add_subdirectory of the repo)
#   run_consumer_test.sh vendored   REPO_DIR       WORK_DIR   (add_subdirectory of a copy of
#                                                              shadows/ alone, nothing else)
set -euo pipefail
mode=$1 from=$2 work=$3
here=$(cd "$(dirname "$0")" && pwd)
rm -rf "$work" && mkdir -p "$work"
# The main build's compiler and sanitizer flags (the asan preset's -fsanitize=...), so that the
# consumer links against the module built with them (tests/CMakeLists.txt passes them).
flags=(-DCMAKE_CXX_FLAGS="${CSM_CONSUMER_CXX_FLAGS:-}"
       -DCMAKE_EXE_LINKER_FLAGS="${CSM_CONSUMER_LINKER_FLAGS:-}")

# The integration (everything the consumer does with the module: the integration header and
# each line of main.cpp that uses the view) stays within 40 lines of code.
lines=$( (cat "$here/shadows_integration.hpp";
          grep -E 'shadows' "$here/main.cpp") | grep -vE '^\s*$|^\s*//|^\s*#include' | wc -l)
echo "integration: $lines lines of code"
[[ $lines -le 40 ]] || { echo "FAIL: integration has $lines lines (limit 40)"; exit 1; }

if [[ $mode == installed ]]; then
  cmake --install "$from" --prefix "$work/prefix" >/dev/null
  cmake -S "$here" -B "$work/build" -G Ninja -DCMAKE_BUILD_TYPE=Release "${flags[@]}" \
        -Dcsm_DIR="$work/prefix/lib/cmake/csm" >/dev/null
elif [[ $mode == vendored ]]; then
  # The folder alone, copied where nothing else of the repo is reachable.
  mkdir -p "$work/vendor"
  cp -r "$from/shadows" "$work/vendor/shadows"
  cmake -S "$here" -B "$work/build" -G Ninja -DCMAKE_BUILD_TYPE=Release "${flags[@]}" \
        -DCSM_SHADOWS_DIR="$work/vendor/shadows" >/dev/null
else
  cmake -S "$here" -B "$work/build" -G Ninja -DCMAKE_BUILD_TYPE=Release "${flags[@]}" \
        -DCSM_SOURCE_DIR="$from" >/dev/null
  # Only the module's targets were configured: no engine, sample world, tests or tools.
  for t in csm_engine csm_sample_world csm_unit_tests csm_bench; do
    if ninja -C "$work/build" -t targets all | grep -q "^$t:"; then
      echo "FAIL: add_subdirectory configured $t"; exit 1
    fi
  done
fi
cmake --build "$work/build" -j 2 >/dev/null
"$work/build/csm_consumer" "$work/consumer.png"
"$work/build/csm_consumer_check" "$work/consumer.png"
