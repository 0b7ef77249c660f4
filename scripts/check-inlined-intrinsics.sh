#!/usr/bin/env bash
# Fails when the release CLI (cli/, binary `kdbeam`) calls a `core::arch` intrinsic out of line.
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

# Each out-of-line call to an intrinsic, with the function that makes it.
calls="$(objdump -d --no-show-raw-insn -C "$binary" | awk '
  /^[0-9a-f]+ <.*>:$/ { caller = $0 }
  /call.*core_arch/ && caller !~ /std_detect/ { print caller " calls " $NF }
')"
if [ -n "$calls" ]; then
  echo "intrinsics called out of line (not inlined into an ISA entry point):"
  echo "$calls"
  exit 1
fi
echo "no intrinsic is called out of line in $binary"
