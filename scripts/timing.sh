#!/usr/bin/env bash
# End-to-end timings on this machine, side by side in one run: the product's fits
# against the paper-faithful baseline (simplex optimizer on a quadrature objective).
# Usage: bash scripts/timing.sh   (from anywhere; builds the release binary first)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q
bin=target/release/lobefit
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

t() { # t LABEL CMD... : wall seconds of CMD (exit status ignored, reported)
  local label=$1; shift
  local s e rc=0
  s=$(date +%s.%N)
  "$@" >"$tmp/out" 2>"$tmp/err" || rc=$?
  e=$(date +%s.%N)
  local secs
  secs=$(awk -v a="$s" -v b="$e" 'BEGIN{print b-a}')
  printf '%-44s %8.3f s  (exit %d)\n' "$label" "$secs" "$rc" >&2
  echo "$secs"
}

echo "machine: $(nproc) cores" >&2
all=$(t "build-tables (all families)" $bin build-tables --out "$tmp")
fast=$(t "fit cap-exponent --method fast" $bin fit cap-exponent --out "$tmp/fast.lobefit")
paper=$(t "fit cap-exponent --method paper (baseline)" $bin fit cap-exponent --method paper --out "$tmp/paper.lobefit")
grep -o '[0-9]* of [0-9]* fits did not converge' "$tmp/err" >&2 || echo "baseline: all fits converged" >&2
lp=$(t "build-tables lobe-product (both variants)" $bin build-tables --only lobe-product --only lobe-product-l2 --out "$tmp")
one=$(t "build-tables --threads 1" $bin build-tables --threads 1 --out "$tmp")
quick=$(t "check --quick" $bin check --quick)
full=$(t "check (10 000 points per family)" $bin check)
printf 'ratio paper/fast (cap-exponent, same 1000 nodes): %.0fx\n' "$(awk -v a="$paper" -v b="$fast" 'BEGIN{print a/b}')" >&2
printf 'ratio 1 thread / all threads (build-tables):      %.2fx\n' "$(awk -v a="$one" -v b="$all" 'BEGIN{print a/b}')" >&2
printf 'lobe-product tables (target <= 10 s):            %.2f s\n' "$lp" >&2
# The Meunier pipeline against its Monte Carlo reference at equal error (one process):
t "render meunier (fig13, 96 px, 1024 spp)" $bin render meunier --scene fig13 --width 96 --spp 1024 --out "$tmp/render" >/dev/null
grep -h "shading time" "$tmp/render/meunier-fig13-summary.txt" >&2
# Per-fit fast vs paper on the same grid points, and runtime lookups, side by side:
echo "lobe-product fast vs paper per fit: cargo bench --bench lobe_product" >&2
