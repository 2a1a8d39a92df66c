#!/usr/bin/env python3
"""Writes assets/scenes/shexp-spheres-*.json: spheres under the whale's SG sky over flat
ground, scenes independent of the ones the SH-exponentiation pipeline's settings were
chosen on (docs/shexp-render.md, "Independent scenes"), and shexp-whale-sh.json, the
whale under an SH sky. Deterministic: the same files every run. 12 large or 60 small non-overlapping spheres, diffuse (Lambert 0.7) or Phong 3
(a Lafortune lobe of exponent 3, specular 0.3, diffuse 0.5) on the spheres; the ground is
Lambert 0.7 in both."""
import json
import random
import sys
from pathlib import Path

root = Path(__file__).resolve().parent.parent
whale = json.loads((root / "pipelines/shexp/scenes/whale.json").read_text())
out = root / "assets/scenes"
out.mkdir(parents=True, exist_ok=True)


def spheres(count, rmin, rmax, seed):
    rng = random.Random(seed)
    placed = []
    while len(placed) < count:
        r = rng.uniform(rmin, rmax)
        c = [rng.uniform(-2.8, 2.8), rng.uniform(-2.8, 2.8), rng.uniform(r + 0.05, 2.6)]
        if all(sum((a - b) ** 2 for a, b in zip(c, q)) ** 0.5 > r + s + 0.02 for q, s in placed):
            placed.append((c, r))
    return [([round(v, 4) for v in c], round(r, 4)) for c, r in placed]


for count, rmin, rmax, seed in [(12, 0.35, 0.6, 12), (60, 0.15, 0.3, 60)]:
    for kind, material in [
        ("diffuse", {"lambert": {"albedo": 0.7}}),
        (
            "phong3",
            {"lafortune": {"albedo": 0.5, "lobes": [{"c": [-1.0, -1.0, 1.0], "exponent": 3.0, "specular": 0.3}]}},
        ),
    ]:
        scene = {
            "version": 1,
            "camera": {"eye": [0.0, -8.0, 6.0], "target": [0.0, 0.0, 0.8], "fov": 0.8},
            "environment": whale["environment"],
            "heightfield": {"size": 2, "extent": 8.0, "heights": [0.0, 0.0, 0.0, 0.0],
                            "material": {"lambert": {"albedo": 0.7}}},
            "spheres": [{"centre": c, "radius": r, "material": material} for c, r in spheres(count, rmin, rmax, seed)],
            "brdf": {"lambert": {"albedo": 0.7}},
        }
        path = out / f"shexp-spheres{count}-{kind}.json"
        path.write_text(json.dumps(scene, indent=1) + "\n")
        print(path.relative_to(root), file=sys.stderr)

# The whale and its terrain under an order-3 SH sky (brighter above, positive
# everywhere): the device's Monte Carlo under an SH environment (docs/gpu.md, "SH skies").
sh = {k: v for k, v in whale.items() if k != "environment"}
sh["sh_environment"] = {"order": 3, "coefficients": [2.0, 0.3, 1.0, -0.2, 0.1, 0.0, 0.2, 0.0, -0.1]}
path = out / "shexp-whale-sh.json"
path.write_text(json.dumps(sh, indent=1) + "\n")
print(path.relative_to(root), file=sys.stderr)
