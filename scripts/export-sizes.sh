#!/usr/bin/env bash
# Error against bytes of the GPU export: every textured family at several resolutions
# (--scale) in f32 and f16, manual filtering; prints family, scale, storage, bytes, and
# each measured error beside its target (from the manifests).
# Usage: bash scripts/export-sizes.sh [scales...]   (default: 0.25 0.5 1 2)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q
scales=${*:-0.25 0.5 1 2}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for s in $scales; do
  for st in f32 f16; do
    ./target/release/lobefit export --format raw --storage "$st" --scale "$s" --allow-lossy --out "$tmp/$s-$st" >/dev/null
    python3 - "$tmp/$s-$st/manifest.json" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
for t in m["families"]:
    errs = "  ".join(f'{e["output"]} {e["metric"]} {e["measured"]:.2e}/{e["target"]:.0e}'
                     for e in t["error"] if e["filter"] == "manual")
    print(f'{t["family"]:<13} scale {m["scale"]:<5} {m["storage"]} {sum(x["bytes"] for x in t["textures"]):>8} B  {errs}')
PY
  done
done
