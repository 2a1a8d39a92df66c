#!/usr/bin/env bash
# Each GPU kernel's µs per pixel on this machine's adapter (lavapipe where there is no
# GPU) against the CPU pipeline's, at the same width and one thread each
# (LP_NUM_THREADS=1, RAYON_NUM_THREADS=1), in alternated runs: GPU bench, CPU renders,
# three times; prints every run and the medians of the per-run ratios.
#
#   scripts/kernel_ratio.sh EXPORT_DIR [WIDTH] [RUNS]
#
# EXPORT_DIR: `lobefit export --format ktx2 --precision f32 --out DIR`. Needs a built
# `target/release/lobefit` and `target/debug/lobefit-gpu` (cargo build -p lobefit-gpu);
# LOBEFIT_GPU=PATH runs another build of lobefit-gpu (a before/after comparison).
set -euo pipefail
export=${1:?usage: scripts/kernel_ratio.sh EXPORT_DIR [WIDTH] [RUNS]}
width=${2:-48}
runs=${3:-3}
export LP_NUM_THREADS=1 RAYON_NUM_THREADS=1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for r in $(seq "$runs"); do
  "${LOBEFIT_GPU:-./target/debug/lobefit-gpu}" bench --export "$export" --out "$tmp/b$r" --width "$width" --frames 3 \
    --only isg,shexp,meunier --mc-spp-max 0 > /dev/null 2>&1
  # bench.md rows: | pipeline | scene | method | size | pixels | ms/frame | ...
  awk -F'|' '$2 ~ /isg|shexp|meunier/ { gsub(/ /, "", $2); gsub(/ /, "", $6); gsub(/ /, "", $7);
    printf "%s %s\n", $2, 1000 * $7 / $6 }' "$tmp/b$r/bench.md" > "$tmp/gpu$r"
  for p in "isg fig12" "shexp whale" "meunier fig13"; do
    set -- $p
    line=$(./target/release/lobefit render "$1" --scene "$2" --width "$width" --threads 1 --spp 16 \
      --out "$tmp/c.png" 2>&1 | grep -m1 -E "time per pixel(:| \(default)")
    # ISG and SH: "time per pixel: <method> X µs"; Meunier: "shading time per pixel
    # (default light cap): lobes X µs".
    us=$(echo "$line" | sed -E 's/.*time per pixel[^:]*: [^0-9]*([0-9.]+) µs.*/\1/')
    echo "$1 $us" >> "$tmp/cpu$r"
  done
done
python3 - "$tmp" "$runs" "$width" <<'EOF'
import statistics, sys
tmp, runs, width = sys.argv[1], int(sys.argv[2]), sys.argv[3]
def read(f):
    return dict((a, float(b)) for a, b in (l.split() for l in open(f)))
print(f"width {width}, one thread each, {runs} alternated runs (µs per pixel)")
for p in ["isg", "shexp", "meunier"]:
    g = [read(f"{tmp}/gpu{r}")[p] for r in range(1, runs + 1)]
    c = [read(f"{tmp}/cpu{r}")[p] for r in range(1, runs + 1)]
    ratios = [a / b for a, b in zip(g, c)]
    print(f"{p:8} adapter {' '.join(f'{x:.1f}' for x in g)}  CPU {' '.join(f'{x:.1f}' for x in c)}  "
          f"ratio median {statistics.median(ratios):.2f} ({min(ratios):.2f}–{max(ratios):.2f})")
EOF
