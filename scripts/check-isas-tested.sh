#!/usr/bin/env bash
# Prints which ISAs the lane tests ran on, and fails when this CPU has AVX-512 (F/BW/DQ/VL) or
# AVX2 + FMA but the tests skipped it. The CPU's flags are read from /proc/cpuinfo, not from the
# detection the tests themselves use, so that a broken detection cannot hide a skipped ISA.
set -euo pipefail
cd "$(dirname "$0")/.."

output="$(cargo test -p kdbeam-kernels --features std --test lanes every_f32_op_matches_scalar_lane_by_lane -- --nocapture 2>&1)"
ran="$(grep -m1 '^ran on' <<<"$output" || true)"
if [ -z "$ran" ]; then
  echo "the lane test printed no 'ran on' line:"
  echo "$output"
  exit 1
fi
echo "ISAs tested: $ran"

flags="$(grep -m1 '^flags' /proc/cpuinfo || true)"
has() {
  for f in "$@"; do
    grep -qw "$f" <<<"$flags" || return 1
  done
}
check() {
  local isa="$1"
  shift
  if has "$@"; then
    if ! grep -q "ran on \[.*\b$isa\b.*\];" <<<"$ran"; then
      echo "this CPU has $* but the tests skipped $isa"
      exit 1
    fi
  else
    echo "this CPU lacks one of $*: $isa skipped"
  fi
}
check Sse sse4_1
check Avx2 avx2 fma
check Avx512 avx2 fma avx512f avx512bw avx512dq avx512vl
