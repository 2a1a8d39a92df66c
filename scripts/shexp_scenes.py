#!/usr/bin/env python3
"""Writes the SH-exponentiation pipeline's built-in scenes (pipelines/scenes/shexp-*.json):
a 256² procedural terrain under an SG sky with a 50-sphere "whale" (Phong or diffuse)
and a 402-sphere "wrecking ball". Deterministic: run it again, get the same files."""
import json, math, os

HERE = os.path.join(os.path.dirname(__file__), "..", "pipelines", "scenes")

def unit(v):
    n = math.sqrt(sum(x * x for x in v))
    return [round(x / n, 12) for x in v]

# A sky the order-4 band limit can carry in part: a broad sun and a dome.
SKY = {"sgs": [
    {"axis": unit([0.5, -0.35, 0.79]), "sharpness": 12.0, "amplitude": 8.0},
    {"axis": [0.0, 0.0, 1.0], "sharpness": 1.5, "amplitude": 0.8},
    {"axis": unit([-0.6, 0.5, 0.62]), "sharpness": 4.0, "amplitude": 0.6},
    {"axis": unit([0.2, 0.9, 0.4]), "sharpness": 3.0, "amplitude": 0.4},
]}
CAMERA = {"eye": [0.0, -8.0, 8.0], "target": [0.0, 0.0, 1.8], "fov": 0.8}
TERRAIN_MAT = {"lambert": {"albedo": 0.7}}
PHONG = {"lafortune": {"albedo": 0.5, "lobes": [{"c": [-1.0, -1.0, 1.0], "exponent": 4.0, "specular": 0.3}]}}
DIFFUSE = {"lambert": {"albedo": 0.7}}

def terrain():
    return {"size": 256, "extent": 8.0,
            "procedural": {"amplitude": 2.5, "octaves": 5, "seed": 7},
            "material": TERRAIN_MAT}

def whale(mat):
    """50 spheres along a curved body, thick in front, thin at the tail, floating."""
    out = []
    for k in range(50):
        s = k / 49.0
        x = -1.8 + 3.6 * s
        y = 0.35 * math.sin(2.0 * s)
        z = 3.1 + 0.25 * math.sin(math.pi * s)
        r = 0.12 + 0.38 * math.sin(math.pi * min(1.0, 0.25 + 0.9 * s)) ** 2 * (1.0 - 0.6 * s)
        out.append({"centre": [round(x, 6), round(y, 6), round(z, 6)], "radius": round(r, 6), "material": mat})
    return out

def wrecking(mat):
    """A ball of 400 spheres (radius 0.11 on a Fibonacci shell) and a chain of 2."""
    out = []
    c = (0.3, 0.4, 3.4)
    big = 0.85
    golden = math.pi * (3.0 - math.sqrt(5.0))
    for k in range(400):
        z = 1.0 - 2.0 * (k + 0.5) / 400.0
        rr = math.sqrt(1.0 - z * z)
        p = golden * k
        d = (rr * math.cos(p), rr * math.sin(p), z)
        out.append({"centre": [round(c[i] + big * d[i], 6) for i in range(3)], "radius": 0.11, "material": mat})
    for k in range(2):
        out.append({"centre": [c[0], c[1], round(c[2] + big + 0.35 + 0.5 * k, 6)], "radius": 0.18, "material": mat})
    return out

def write(name, spheres):
    scene = {"version": 1, "camera": CAMERA, "environment": SKY, "heightfield": terrain(),
             "spheres": spheres, "brdf": DIFFUSE}
    with open(os.path.join(HERE, f"shexp-{name}.json"), "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")

write("whale", whale(PHONG))
write("whale-diffuse", whale(DIFFUSE))
write("wrecking", wrecking(PHONG))
