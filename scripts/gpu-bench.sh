#!/usr/bin/env bash
# The analytic render kernels timed on whatever Vulkan adapter wgpu finds (a GPU, or
# lavapipe without one), at the papers' settings, and against the device's Monte Carlo:
# builds, exports the tables and runs `lobefit-gpu bench` once per setting; each run
# writes OUT/NAME/bench.json and bench.md (adapter, timing source, ms/frame median and
# min–max, error against the CPU pipeline, static SPIR-V counts). Image height 3/4 of
# the width.
#   monte-carlo  width 32 (at 64 the ISG error is below the reference's resolution):
#                the ISG (fig12), SH-exponentiation (whale, its terrain traced on
#                the device too) and Meunier (fig13) kernels against the device's
#                Monte Carlo at 1 … 65 536 spp, each image against a CPU reference
#                of 16 384 spp a pixel
#   iwasaki      640 × 480 (Iwasaki et al., Table 1): ISG on fig12 (50 spheres), rigs
#   iwasaki-306  640 × 480, the ISG sweep's 306 spheres (Table 1's largest)
#   giraud       960 × 720 (Giraud: 960 × 540): SH exponentiation on whale (50 spheres)
#   giraud-402   960 × 720, the 402-sphere wrecking ball
#   meunier      148 × 111 = 16 428 pixels (Meunier Fig. 17: 16 384 points), fig13
#   full-640     640 × 480: the three kernels against the device's Monte Carlo at
#                1 … 4 096 spp, the reference the device's own (16 384 spp a pixel,
#                checked against the CPU's on 256 pixels: --reference device)
#   full-1920    1920 × 1440, the same at 1 … 1 024 spp (3 frames)
# The CPU renders the same images for the comparison: minutes at these sizes. On a CPU
# adapter (lavapipe) iwasaki-306 is refused (llvmpipe's loop budget; the script goes
# on and says so) and the rest takes long: the numbers are indicative only there.
# Usage: bash scripts/gpu-bench.sh [OUT] [FRAMES]   (default gpu-bench/, 10 frames;
# LOBEFIT_BIN=DIR: take lobefit and lobefit-gpu already built in DIR, no cargo build)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-gpu-bench}
frames=${2:-10}
bin=${LOBEFIT_BIN:-target/release}
if [ -z "${LOBEFIT_BIN:-}" ]; then
  cargo build --release -q -p lobefit -p lobefit-gpu
fi
mkdir -p "$out"
"$bin/lobefit" export --format ktx2 --out "$out/export"
refused=()
bench() {
  local name=$1
  shift
  printf '\n== %s\n' "$name"
  if ! "$bin/lobefit-gpu" bench --export "$out/export" --frames "${FRAMES:-$frames}" --out "$out/$name" "$@"; then
    refused+=("$name")
  fi
}
bench monte-carlo --width 32 --only isg,shexp,meunier --mc-spp-max 65536
bench iwasaki --width 640 --only isg,rigs --mc-spp-max 0
bench giraud --width 960 --only shexp --mc-spp-max 0
bench meunier --width 148 --only meunier --mc-spp-max 0
bench iwasaki-306 --width 640 --only isg --scene isg=sweep-306 --mc-spp-max 0
bench giraud-402 --width 960 --only shexp --scene shexp=wrecking --mc-spp-max 0
bench full-640 --width 640 --only isg,shexp,meunier --mc-spp-max 4096 --reference device
FRAMES=3 bench full-1920 --width 1920 --only isg,shexp,meunier --mc-spp-max 1024 --reference device
cat "$out"/*/bench.md
if [ ${#refused[@]} -gt 0 ]; then
  echo "not benched (see their errors above): ${refused[*]}"
  exit 1
fi
