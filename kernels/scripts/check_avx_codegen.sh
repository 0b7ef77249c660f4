#!/usr/bin/env bash
# Proves that a kernel run through `Avx::run` compiles to 256-bit AVX code (ymm registers) with
# FMA, although the crate is built for baseline x86-64 (no -C target-cpu): disassembles the
# `#[target_feature(enable = "avx2,fma")]` entry point `enter_avx2_fma`, instantiated only for the
# probe task of kernels/tests/avx_codegen.rs (the one task that binary defines), and counts its
# ymm, vfmadd and legacy (non-VEX) SSE packed instructions. Exits non-zero unless there are ymm
# and vfmadd instructions and no legacy SSE ones. Needs objdump (binutils).
set -euo pipefail
cd "$(dirname "$0")/../.."
bin=$(cargo test -p kdbeam-kernels --features std --test avx_codegen --no-run --message-format=json 2>/dev/null \
    | grep -o '"executable":"[^"]*avx_codegen[^"]*"' | tail -n 1 | cut -d'"' -f4)
[ -x "$bin" ] || { echo "test binary not found" >&2; exit 1; }
body=$(objdump -d -C --no-show-raw-insn "$bin" \
    | awk '/^[0-9a-f]+ <kdbeam_kernels::lanes::avx::enter_avx2_fma>:$/ {on = 1; print; next} on && /^$/ {on = 0; done = 1} on && !done')
[ -n "$body" ] || { echo "entry point enter_avx2_fma not found in $bin" >&2; exit 1; }
ymm=$(grep -c 'ymm' <<<"$body" || true)
fma=$(grep -c 'vfmadd' <<<"$body" || true)
xmm_only=$(grep -Ec '\s(mulps|addps|divps|subps|minps|maxps)\s' <<<"$body" || true)
echo "enter_avx2_fma (probe): $(wc -l <<<"$body") lines, $ymm with ymm, $fma vfmadd, $xmm_only legacy-SSE packed ops"
[ "$ymm" -gt 0 ] && [ "$fma" -gt 0 ] && [ "$xmm_only" -eq 0 ]
