#!/usr/bin/env bash
# Builds the libFuzzer harnesses (clang, -fsanitize=fuzzer,address,undefined) and runs each.
#   tools/fuzz.sh [SECONDS | -runs=N]    default: 20 s each (what CI runs)
# Harnesses: obj, ply, off (the --mesh readers and what a parsed mesh goes through next) and
# config (the --config JSON and --set parsers). Seeds: tests/fuzz/corpus/<name> (checked in);
# the growing corpus and any crash files go to build-fuzz/. Exit status non-zero on any finding
# (crash, sanitizer report, leak, timeout, out-of-memory).
set -euo pipefail
cd "$(dirname "$0")/.."
limit=${1:-20}
if [[ $limit == -runs=* ]]; then budget=("$limit"); else budget=(-max_total_time="$limit"); fi
out=build-fuzz
mkdir -p "$out"
cxx=${CXX_FUZZ:-clang++-14}
# Objects are instrumented for coverage (fuzzer-no-link) and compiled once; each harness links
# them with -fsanitize=fuzzer (libFuzzer's main).
flags=(-std=c++20 -O1 -g -DNDEBUG -fsanitize=address,undefined -fno-sanitize-recover=all
       -fno-omit-frame-pointer -Isample_world/include -Isample_world/src -Ishadows/include
       -Iengine/include)
headers=(sample_world/src/*.hpp sample_world/include/sample_world/*.hpp shadows/include/csm/*.hpp
         engine/include/engine/*.hpp
         tools/fuzz.sh)
mkdir -p "$out/obj"
# Compiles and fuzzer runs go nproc at a time (each is single-threaded); a batch is waited for
# pid by pid, so that every failure is seen.
parallel=$(nproc)
pids=()
wait_batch() {
  local p
  for p in "${pids[@]}"; do wait "$p"; done  # set -e: a failed compile stops the script
  pids=()
}
object() {  # source [defines...] -> prints the object's path; compiled (in the background) when
  local src=$1  # anything is newer
  shift
  local obj="$out/obj/$(echo "$src $*" | tr -c 'A-Za-z0-9_.\n' '_').o"
  local newest
  newest=$(ls -t "$src" "${headers[@]}" | head -n1)
  if [[ ! -f $obj || $newest -nt $obj ]]; then
    if (( ${#pids[@]} >= parallel )); then wait_batch >&2; fi
    echo "fuzz.sh: compiling $src $*" >&2
    "$cxx" "${flags[@]}" -fsanitize=fuzzer-no-link "$@" -c "$src" -o "$obj" &
    pids+=("$!")
  fi
  objects+=("$obj")
}
link() {  # name objects...
  local name=$1
  shift
  "$cxx" "${flags[@]}" -fsanitize=fuzzer "$@" -o "$out/fuzz_$name" -lOpenMeshCore -lOpenMeshTools
}
objects=()
object sample_world/src/mesh_parse.cpp
object sample_world/src/mesh_ops.cpp
mesh_objs=("${objects[@]}")
harness_objs=()
for f in obj ply off; do
  objects=()
  object tests/fuzz/fuzz_mesh.cpp -DCSM_FUZZ_FORMAT=\"$f\"
  harness_objs+=("${objects[0]}")
done
objects=()
object tests/fuzz/fuzz_config.cpp
object sample_world/src/settings.cpp
for c in shadows/src/core/*.cpp; do object "$c"; done
config_objs=("${objects[@]}")
wait_batch
k=0
for f in obj ply off; do
  link "$f" "${harness_objs[$k]}" "${mesh_objs[@]}" &
  pids+=("$!")
  k=$((k + 1))
done
link config "${config_objs[@]}" &
pids+=("$!")
wait_batch

status=0
run() {  # name: one harness for the budget; its output in $out/log_NAME.txt
  local f=$1
  mkdir -p "$out/corpus_$f" "$out/findings_$f"
  # -rss_limit_mb: 2 GB (the battery's bound); -timeout: 10 s for one input.
  "$out/fuzz_$f" "$out/corpus_$f" "tests/fuzz/corpus/$f" "${budget[@]}" -rss_limit_mb=2048 \
    -timeout=10 -max_len=65536 -artifact_prefix="$out/findings_$f/" -print_final_stats=1 \
    >"$out/log_$f.txt" 2>&1
}
report() {  # name pid: waits for the harness and says what it found
  local f=$1
  if ! wait "$2"; then
    echo "fuzz.sh: $f FOUND SOMETHING: see $out/log_$f.txt and $out/findings_$f/"
    tail -n 40 "$out/log_$f.txt"
    status=1
  fi
  grep -E "stat::number_of_executed_units|stat::peak_rss_mb" "$out/log_$f.txt" | sed "s/^/  $f /"
}
names=(obj ply off config)
for ((i = 0; i < ${#names[@]}; i += parallel)); do
  batch=("${names[@]:i:parallel}")
  running=()
  for f in "${batch[@]}"; do
    echo "fuzz.sh: running $f (${budget[*]})"
    run "$f" &
    running+=("$!")
  done
  for j in "${!batch[@]}"; do report "${batch[$j]}" "${running[$j]}"; done
done
exit $status
