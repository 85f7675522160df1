#!/usr/bin/env bash
# One case of the robustness battery: runs a command and checks how it ended.
#   run_case.sh EXPECTED_EXIT REGEX INPUT_DIR -- COMMAND ARGS...
# @IN@ in the arguments becomes INPUT_DIR (made by make_inputs.sh). Passes when the command
# exits with EXPECTED_EXIT (never a signal), within 30 s (120 s under the sanitizers, which run
# world generation 5-10x slower: 11 s of a 4-frame run on a loaded machine), with a peak RSS under
# 2 GB (and, outside
# sanitizer builds, an address-space limit of 2 GB), and its output matches REGEX (grep -E).
set -uo pipefail
expected=$1 regex=$2 in=$3
shift 3
[[ $1 == -- ]] && shift
args=()
for a in "$@"; do
  a=${a//@IN@/$in}
  [[ $a == @EMPTY@ ]] && a=
  args+=("$a")
done

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
limit_kb=$((2 * 1024 * 1024))
limit_s=30
[[ -n ${CSM_SANITIZED:-} ]] && limit_s=120
(
  # ASan reserves terabytes of address space: there the RSS measurement below is the bound.
  [[ -z ${CSM_SANITIZED:-} ]] && ulimit -v "$limit_kb"
  exec /usr/bin/time -f '%M' -o "$work/rss" timeout -s KILL "$limit_s" "${args[@]}"
) >"$work/out" 2>&1
rc=$?
out=$(cat "$work/out")
rss=$(tail -n1 "$work/rss" 2>/dev/null | grep -Eo '^[0-9]+$' || echo 0)
echo "command: ${args[*]}"
echo "exit: $rc, peak RSS: $((rss / 1024)) MB"
echo "--- output (first 40 lines) ---"
printf '%s\n' "$out" | head -n 40
echo "---"
fail=0
if grep -q 'Command terminated by signal\|Command exited with non-zero status 137' "$work/rss" 2>/dev/null; then
  echo "FAIL: killed by a signal (or the ${limit_s} s limit)"
  fail=1
fi
if ((rc >= 124)); then
  echo "FAIL: exit $rc means a timeout or a signal"
  fail=1
fi
if ((rc != expected)); then
  echo "FAIL: expected exit $expected, got $rc"
  fail=1
fi
if ((rss >= limit_kb)); then
  echo "FAIL: peak RSS $((rss / 1024)) MB >= 2048 MB"
  fail=1
fi
if ! grep -Eq -- "$regex" <<<"$out"; then
  echo "FAIL: output does not match: $regex"
  fail=1
fi
if grep -Eq "AddressSanitizer|runtime error:|LeakSanitizer" <<<"$out"; then
  echo "FAIL: sanitizer report"
  fail=1
fi
exit $fail
