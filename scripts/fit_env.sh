#!/usr/bin/env bash
# The environment-fit table of docs/environment.md: each committed map (assets/envmaps)
# fitted with K RGB SGs by `lobefit fit-env` (release build), its errors on luminance
# against the map's texels beside SH of orders 3 and 5 projected from the same texels:
# radiance L2, irradiance at 1 000 normals (median / max), glossy Phong 10/100/1000 at
# 200 directions (median), and the fit's time. A study, not a check.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "| map | K | fit s | radiance L2: SGs / SH 3 / SH 5 | irradiance median: SGs / SH 3 / SH 5 | irradiance max: SGs / SH 3 / SH 5 | Phong 10 | Phong 100 | Phong 1000 (median: SGs / SH 3 / SH 5) |"
echo "|---|---:|---:|---|---|---|---|---|---|"
for map in ${MAPS:-sky apartment sunset}; do
  for k in ${KS:-4 8 16 24 32}; do
    target/release/lobefit fit-env --map "assets/envmaps/$map.exr" --sgs "$k" --out "$out/f.json" >/dev/null
    python3 - "$map" "$k" "$out/f.json" <<'PY'
import json, sys
m, k, f = sys.argv[1:]
j = json.load(open(f)); r = j["report"]
t = lambda v: " / ".join("%.4f" % x for x in v)
print("| %s | %s | %.2f | %s | %s | %s | %s |" % (
    m, k, j["source"]["seconds"], t(r["radiance"]), t([x[0] for x in r["irradiance"]]),
    t([x[1] for x in r["irradiance"]]), " | ".join(t([x[0] for x in g]) for g in r["glossy"])))
PY
  done
done
