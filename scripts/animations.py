#!/usr/bin/env python3
"""Writes the animated scenes (docs/meshes.md, Motion) from the still ones, so that
their keys are reproducible: pipelines/isg/scenes/falling.json (Figure 12's spheres,
every third dropped from above and bouncing once onto where it rests) and
assets/meshes/isg-bunny-walk.json (the bunny hopping across the plane through the
sun's shadow), assets/meshes/isg-bunny-nod.json (the bunny nodding: a deforming mesh,
two bones), pipelines/meunier/scenes/orbit.json (Figure 13's blockers turning)
and the stills assets/meshes/meunier-bunny.json (the bunny under Figure 13's light)
and assets/meshes/shexp-bunny.json (the bunny under the whale's sky), and
pipelines/shexp/scenes/swim.json (the whale's spheres swimming over the terrain). Run from the repository root: python3 scripts/animations.py"""
import json
import math
import random

G = 40.0          # gravity (scene units per squared animation span: a 2-unit drop takes 0.32)
RESTITUTION = 0.4  # bounce height / drop height

def fall_keys(height, start):
    """(time, z-offset) keys: rest `height` above, fall, one bounce, rest at 0."""
    t_fall = math.sqrt(2 * height / G)
    h2 = RESTITUTION * height
    t_up = math.sqrt(2 * h2 / G)
    keys = [(0.0, height)] if start > 0 else []
    for i in range(7):  # the fall, a parabola sampled at 7 times
        u = i / 6
        keys.append((start + u * t_fall, height * (1 - u * u)))
    for i in range(1, 7):  # the bounce: up and down again
        u = i / 6 * 2 * t_up
        keys.append((start + t_fall + u, max(0.0, math.sqrt(2 * G * h2) * u - 0.5 * G * u * u)))
    keys = [(round(t, 6), round(z, 6)) for t, z in keys if t <= 1.0]
    out = []
    for t, z in keys:  # strictly increasing times
        if not out or t > out[-1][0]:
            out.append((t, z))
    return [{"time": t, "translation": [0.0, 0.0, z]} for t, z in out]

def falling():
    scene = json.load(open("pipelines/isg/scenes/fig12.json"))
    scene["version"] = 2
    rng = random.Random(12)
    for k, s in enumerate(scene["spheres"]):
        if k % 3 == 0:
            s["keys"] = fall_keys(rng.uniform(1.5, 3.0), rng.uniform(0.0, 0.45))
    with open("pipelines/isg/scenes/falling.json", "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")

def bunny_walk():
    scene = json.load(open("assets/meshes/isg-bunny.json"))
    hops, x0, x1, lift = 4, -3.0, 3.0, 0.3
    keys = []
    for i in range(hops):
        for j in range(4):  # take-off, rising, falling (each hop a sampled parabola)
            u = (i + j / 4) / hops
            phase = j / 4
            keys.append({"time": round(u, 6),
                         "translation": [round(x0 + (x1 - x0) * u, 6), 0.0,
                                         round(4 * lift * phase * (1 - phase), 6)]})
    keys.append({"time": 1.0, "translation": [x1, 0.0, 0.0]})
    scene["meshes"][0]["keys"] = keys
    with open("assets/meshes/isg-bunny-walk.json", "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")

def orbit():
    """Meunier's Figure 13 with its five blockers turning half a turn about the
    vertical axis (alternate ones the other way), their shadows sweeping the plane."""
    scene = json.load(open("pipelines/meunier/scenes/fig13.json"))
    scene["version"] = 2
    for k, s in enumerate(scene["spheres"]):
        x, y, _ = s["centre"]
        sign = 1 if k % 2 == 0 else -1
        keys = []
        for i in range(17):
            t = i / 16
            a = sign * math.pi * t
            rx, ry = x * math.cos(a) - y * math.sin(a), x * math.sin(a) + y * math.cos(a)
            keys.append({"time": round(t, 6), "translation": [round(rx - x, 6), round(ry - y, 6), 0.0]})
        s["keys"] = keys
    with open("pipelines/meunier/scenes/orbit.json", "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")

def meunier_bunny():
    """A still: the bunny of isg-bunny.json over Figure 13's plane under its sphere
    light (the Meunier pipeline's proxy-error scene)."""
    scene = json.load(open("pipelines/meunier/scenes/fig13.json"))
    bunny = json.load(open("assets/meshes/isg-bunny.json"))["meshes"][0]
    scene["version"] = 2
    scene["spheres"] = []
    scene["meshes"] = [bunny]
    with open("assets/meshes/meunier-bunny.json", "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")

def shexp_bunny():
    """A still: the bunny of isg-bunny.json on flat ground (a 2 × 2 height field at
    z = 0: the SH pipeline shades no planes) under the whale's sky."""
    scene = json.load(open("pipelines/shexp/scenes/whale.json"))
    bunny = json.load(open("assets/meshes/isg-bunny.json"))["meshes"][0]
    scene["version"] = 2
    scene["spheres"] = []
    scene["meshes"] = [bunny]
    scene["heightfield"] = {"size": 2, "extent": 10.0, "heights": [0.0] * 4,
                            "material": scene["heightfield"]["material"]}
    with open("assets/meshes/shexp-bunny.json", "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")

def swim():
    """The whale of shexp-whale.json swimming over its terrain: every sphere moves
    together 2 units along +x and 0.5 along +y, rising and sinking 0.25 twice (Giraud's
    animated whale kind; the terrain's shadows and the whale's sweep each other)."""
    scene = json.load(open("pipelines/shexp/scenes/whale.json"))
    scene["version"] = 2
    keys = []
    for i in range(17):
        t = i / 16
        keys.append({"time": round(t, 6),
                     "translation": [round(-1.0 + 2.0 * t, 6), round(0.5 * t, 6),
                                     round(0.25 * math.sin(2 * math.pi * t) ** 2, 6)]})
    for s in scene["spheres"]:
        s["keys"] = keys
    with open("pipelines/shexp/scenes/swim.json", "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")

def bunny_nod():
    """The bunny of isg-bunny.json nodding twice: a two-bone bend about the y axis
    through its neck, the head and ears turning up to 0.4 rad, the blend 0.6 units
    wide along up-and-forward; its sphere set carried by the bones."""
    scene = json.load(open("assets/meshes/isg-bunny.json"))
    keys = [{"time": t, "angle": a} for t, a in [(0.0, 0.0), (0.25, 0.4), (0.5, 0.0), (0.75, 0.4), (1.0, 0.0)]]
    scene["meshes"][0]["bend"] = {"pivot": [-0.3, 0.0, 1.2], "axis": [0.0, 1.0, 0.0],
                                  "along": [-0.5, 0.0, 0.85], "width": 0.6, "keys": keys}
    with open("assets/meshes/isg-bunny-nod.json", "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")

falling()
bunny_walk()
bunny_nod()
orbit()
meunier_bunny()
shexp_bunny()
swim()
