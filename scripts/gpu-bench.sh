#!/usr/bin/env bash
# The analytic render kernels timed on whatever Vulkan adapter wgpu finds (a GPU, or
# lavapipe without one), at the papers' image sizes: builds, exports the tables and
# runs `lobefit-gpu bench` once per size; each run writes bench.json and bench.md
# (adapter, timing source, ms/frame median and min–max, error against the CPU
# pipeline, static SPIR-V counts). The image height is 3/4 of the width.
#   Iwasaki et al. Table 1: 640 × 480; Giraud: 960 × 540 (here 960 × 720);
#   Meunier Fig. 17: 16 384 points (here 148 × 111 = 16 428 pixels).
# The CPU pipeline renders the same image for the comparison: minutes at these sizes.
# Then the analytic kernels against the device's Monte Carlo (1 … 65 536 spp) at width
# 64, where the CPU reference (16 384 spp a pixel) takes a minute or two.
# Usage: bash scripts/gpu-bench.sh [OUT] [FRAMES]   (default gpu-bench/, 10 frames)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-gpu-bench}
frames=${2:-10}
cargo build --release -q -p lobefit -p lobefit-gpu
mkdir -p "$out"
target/release/lobefit export --format ktx2 --out "$out/export"
for size in 640:iwasaki 960:giraud 148:meunier; do
  width=${size%%:*}
  name=${size##*:}
  printf '\n== width %s (%s)\n' "$width" "$name"
  target/release/lobefit-gpu bench --export "$out/export" --width "$width" --frames "$frames" \
    --mc-spp-max 0 --out "$out/$name"
done
printf '\n== width 64 (against Monte Carlo on the device)\n'
target/release/lobefit-gpu bench --export "$out/export" --width 64 --frames "$frames" \
  --mc-spp-max 65536 --out "$out/monte-carlo"
cat "$out"/*/bench.md
