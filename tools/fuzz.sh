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
object() {  # source [defines...] -> prints the object's path; rebuilt when anything is newer
  local src=$1
  shift
  local obj="$out/obj/$(echo "$src $*" | tr -c 'A-Za-z0-9_.\n' '_').o"
  local newest
  newest=$(ls -t "$src" "${headers[@]}" | head -n1)
  if [[ ! -f $obj || $newest -nt $obj ]]; then
    echo "fuzz.sh: compiling $src $*" >&2
    "$cxx" "${flags[@]}" -fsanitize=fuzzer-no-link "$@" -c "$src" -o "$obj"
  fi
  echo "$obj"
}
link() {  # name objects...
  local name=$1
  shift
  "$cxx" "${flags[@]}" -fsanitize=fuzzer "$@" -o "$out/fuzz_$name" -lOpenMeshCore -lOpenMeshTools
}
mesh_objs=("$(object sample_world/src/mesh_parse.cpp)" "$(object sample_world/src/mesh_ops.cpp)")
for f in obj ply off; do
  link "$f" "$(object tests/fuzz/fuzz_mesh.cpp -DCSM_FUZZ_FORMAT=\"$f\")" "${mesh_objs[@]}"
done
config_objs=("$(object tests/fuzz/fuzz_config.cpp)" "$(object sample_world/src/settings.cpp)")
for c in shadows/src/core/*.cpp; do config_objs+=("$(object "$c")"); done
link config "${config_objs[@]}"

status=0
for f in obj ply off config; do
  mkdir -p "$out/corpus_$f" "$out/findings_$f"
  echo "fuzz.sh: running $f (${budget[*]})"
  # -rss_limit_mb: 2 GB (the battery's bound); -timeout: 10 s for one input.
  if ! "$out/fuzz_$f" "$out/corpus_$f" "tests/fuzz/corpus/$f" "${budget[@]}" -rss_limit_mb=2048 \
      -timeout=10 -max_len=65536 -artifact_prefix="$out/findings_$f/" -print_final_stats=1 \
      >"$out/log_$f.txt" 2>&1; then
    echo "fuzz.sh: $f FOUND SOMETHING: see $out/log_$f.txt and $out/findings_$f/"
    tail -n 40 "$out/log_$f.txt"
    status=1
  fi
  grep -E "stat::number_of_executed_units|stat::peak_rss_mb" "$out/log_$f.txt" | sed "s/^/  $f /"
done
exit $status
