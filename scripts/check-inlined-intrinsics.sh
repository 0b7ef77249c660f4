#!/usr/bin/env bash
# Fails when the release CLI (cli/, binary `kdbeam`) calls a `core::arch` intrinsic out of line,
# or when its AVX-512 entry points (`enter_avx512`, kernels/src/lanes/avx512.rs) are missing or
# hold no 512-bit (`zmm`) instruction.
#
# The kernels are generic over `Lanes` and reach an ISA's target features only by being inlined
# into its entry point (`kernels/src/lanes/`). Code that is not inlined there (typically the
# closure of an `array::map` or `array::from_fn`, which rustc may leave out of line) runs
# without the ISA's features, so every intrinsic it uses becomes a function call: a kernel
# then gives the same results several times slower, which no test would notice. Only std's
# CPU feature detection may call one (`_xgetbv`).
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v objdump >/dev/null; then
  as_root=()
  if [ "$(id -u)" -ne 0 ]; then
    as_root=(sudo)
  fi
  export DEBIAN_FRONTEND=noninteractive
  "${as_root[@]}" apt-get update
  "${as_root[@]}" apt-get install -y --no-install-recommends binutils
fi

cargo build --release --bin kdbeam
target_dir="$(cargo metadata --format-version 1 --no-deps | sed -n 's/.*"target_directory":"\([^"]*\)".*/\1/p')"
binary="$target_dir/release/kdbeam"

disassembly="$(objdump -d --no-show-raw-insn -C "$binary")"

# Each out-of-line call to an intrinsic, with the function that makes it.
calls="$(printf '%s\n' "$disassembly" | awk '
  /^[0-9a-f]+ <.*>:$/ { caller = $0 }
  /call.*core_arch/ && caller !~ /std_detect/ { print caller " calls " $NF }
')"
if [ -n "$calls" ]; then
  echo "intrinsics called out of line (not inlined into an ISA entry point):"
  echo "$calls"
  exit 1
fi
echo "no intrinsic is called out of line in $binary"

# The AVX-512 path: its entry points, and the `zmm` instructions inside them. An x86-64 build
# that has the path but compiles it without 512-bit instructions runs the 16-lane kernels as
# something else (or not at all), which the tests, comparing results only, would not notice.
if [ -f kernels/src/lanes/avx512.rs ] && [ "$(uname -m)" = x86_64 ]; then
  read -r entries zmm < <(printf '%s\n' "$disassembly" | awk '
    /^[0-9a-f]+ <.*>:$/ { inside = ($0 ~ /enter_avx512/); if (inside) entries++ }
    inside && /%zmm/ { zmm++ }
    END { print entries + 0, zmm + 0 }
  ')
  if [ "$entries" -eq 0 ]; then
    echo "the build has the AVX-512 path but $binary has no enter_avx512 entry point"
    exit 1
  fi
  if [ "$zmm" -eq 0 ]; then
    echo "the $entries AVX-512 entry points of $binary contain no zmm instruction"
    exit 1
  fi
  echo "$entries AVX-512 entry points with $zmm zmm instructions in $binary"
fi
