#!/usr/bin/env bash
# The sphere-fit table of docs/meshes.md: every method × count × mesh (the bunny and
# the torus knot; the skinned walker in its bind pose) → volume error (excess, missed), overlap, both Hausdorff distances
# (of the diagonal) and the fit's time, from `lobefit spheres` (release build, seed 0,
# 200 000 quality samples). A study, not a check: times are this machine's.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q
bin=target/release/lobefit
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "| mesh | method | count | volume error | excess | missed | overlap | H mesh→spheres | H spheres→mesh | fit s |"
echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"
for file in ${MESHES:-bunny.obj knot.obj walker.gltf}; do
  mesh=${file%.*}
  for count in ${COUNTS:-8 16 32 64 128 256}; do
    for method in kmeans kmeans-moment tree cover optimize "optimize --max-overlap 1.2"; do
      # shellcheck disable=SC2086
      line=$($bin spheres --mesh "assets/meshes/$file" --count "$count" --method $method --out "$out/s.json" | tr '\n' ' ')
      python3 - "$mesh" "$method" "$count" "$line" <<'PY'
import re, sys
mesh, method, count, line = sys.argv[1:]
g = lambda p: float(re.search(p, line).group(1))
v = [g(r'volume error ([0-9.]+)'), g(r'excess ([0-9.]+)'), g(r'missed ([0-9.]+)'), g(r'overlap ([0-9.]+)'),
     g(r'\(([0-9.]+) of the diagonal\)'), g(r'spheres → mesh [0-9.e+-]+ \(([0-9.]+)\)'), g(r' in ([0-9.]+) s')]
print("| %s | %s | %s | %.3f | %.3f | %.3f | %.2f | %.4f | %.4f | %.2f |" % (mesh, method, count, *v))
PY
    done
  done
done
