#!/usr/bin/env python3
"""Writes assets/meshes/walker.gltf (or argv[1]): a skinned, walking mannequin.

No CC0 skinned character is published on a package registry this project can fetch
(docs/meshes.md), so this one is built here, under the project's licence. glTF 2.0,
y up, facing +z, about 1.86 units tall, one embedded buffer:

- six closed parts that never overlap (the sphere fit's inside test takes the parity
  of rays): an ellipsoid torso, a sphere head, and four limbs, each one capped tube
  over two bones (thigh and shin, upper arm and forearm) whose vertices blend the two
  bones' transforms across the knee or elbow (linear blend skinning, smoothstep
  weights over 0.14 units);
- 11 joints (hips, spine, head, and two per limb), inverse bind matrices, JOINTS_0
  (u8) and WEIGHTS_0 (f32, summing to 1);
- one animation, "walk": a 1 s loop keyed every 1/16 s (LINEAR): the thighs swing
  ±0.45 rad in opposition, each knee flexes while its leg swings forward, the arms
  swing against the legs, and the hips bob 0.02 units twice a cycle.

Pure Python (no numpy): `python3 scripts/walker.py`.
"""
import base64
import json
import math
import struct
import sys

# ---- joints: name, parent, translation from the parent (bind pose: no rotations) ----
JOINTS = [
    ("hips", None, (0.0, 1.0, 0.0)),
    ("spine", 0, (0.0, 0.3, 0.0)),
    ("head", 1, (0.0, 0.45, 0.0)),
    ("thigh_l", 0, (0.11, 0.0, 0.0)),
    ("shin_l", 3, (0.0, -0.47, 0.0)),
    ("thigh_r", 0, (-0.11, 0.0, 0.0)),
    ("shin_r", 5, (0.0, -0.47, 0.0)),
    ("upperarm_l", 1, (0.30, 0.22, 0.0)),
    ("forearm_l", 7, (0.0, -0.29, 0.0)),
    ("upperarm_r", 1, (-0.30, 0.22, 0.0)),
    ("forearm_r", 9, (0.0, -0.29, 0.0)),
]


def bind_position(j):
    x, y, z = 0.0, 0.0, 0.0
    while j is not None:
        t = JOINTS[j][2]
        x, y, z = x + t[0], y + t[1], z + t[2]
        j = JOINTS[j][1]
    return (x, y, z)


V, F, JW = [], [], []  # positions, triangles, [(joint, weight), ...] per vertex


def add_grid(rings, closed_top, closed_bottom):
    """rings: list of (list of points, weights); joins consecutive rings, caps the ends
    with a pole vertex each (given as a one-point ring)."""
    base = len(V)
    offsets = []
    for pts, w in rings:
        offsets.append(len(V))
        for p in pts:
            V.append(p)
            JW.append(w)
    for r in range(len(rings) - 1):
        a, b = offsets[r], offsets[r + 1]
        na, nb = len(rings[r][0]), len(rings[r + 1][0])
        if na == 1:  # top pole to ring
            for k in range(nb):
                F.append((a, b + k, b + (k + 1) % nb))
        elif nb == 1:  # ring to bottom pole
            for k in range(na):
                F.append((a + k, b, a + (k + 1) % na))
        else:
            for k in range(na):
                k1 = (k + 1) % na
                F.append((a + k, b + k, b + k1))
                F.append((a + k, b + k1, a + k1))
    return base


def ellipsoid(centre, radii, joint, n_lat=14, n_lon=24):
    rings = [([(centre[0], centre[1] + radii[1], centre[2])], [(joint, 1.0)])]
    for i in range(1, n_lat):
        th = math.pi * i / n_lat
        pts = []
        for k in range(n_lon):
            ph = 2 * math.pi * k / n_lon
            pts.append((
                centre[0] + radii[0] * math.sin(th) * math.cos(ph),
                centre[1] + radii[1] * math.cos(th),
                centre[2] - radii[2] * math.sin(th) * math.sin(ph),
            ))
        rings.append((pts, [(joint, 1.0)]))
    rings.append(([(centre[0], centre[1] - radii[1], centre[2])], [(joint, 1.0)]))
    add_grid(rings, True, True)


def smoothstep(e0, e1, x):
    s = min(max((x - e0) / (e1 - e0), 0.0), 1.0)
    return s * s * (3 - 2 * s)


def limb(x, top, mid, bottom, r_top, r_bottom, upper, lower, n_rings=26, n_around=12, cap=4):
    """A vertical capped tube at x from y = top down to y = bottom (z = 0), its radius
    from r_top to r_bottom; weights blend upper -> lower across y = mid."""
    def ring(y, r):
        w = smoothstep(mid + 0.07, mid - 0.07, y)  # 0 above the joint, 1 below
        ws = [(upper, 1.0 - w), (lower, w)] if 0.0 < w < 1.0 else [(lower if w >= 1.0 else upper, 1.0)]
        pts = [(x + r * math.cos(2 * math.pi * k / n_around), y, -r * math.sin(2 * math.pi * k / n_around))
               for k in range(n_around)]
        return pts, ws

    def radius(y):
        return r_top + (r_bottom - r_top) * (top - y) / (top - bottom)

    rings = []
    # rounded top: a quarter circle of `cap` rings above y = top - r_top
    rt = r_top
    rings.append(([(x, top, 0.0)], [(upper, 1.0)]))
    for i in range(1, cap):
        a = (math.pi / 2) * i / cap
        rings.append(ring(top - rt + rt * math.cos(a), rt * math.sin(a)))
    y0, y1 = top - rt, bottom + r_bottom
    for i in range(n_rings + 1):
        y = y0 + (y1 - y0) * i / n_rings
        rings.append(ring(y, radius(y)))
    rb = r_bottom
    for i in range(cap - 1, 0, -1):
        a = (math.pi / 2) * i / cap
        rings.append(ring(bottom + rb - rb * math.cos(a), rb * math.sin(a)))
    rings.append(([(x, bottom, 0.0)], [(lower, 1.0)]))
    add_grid(rings, True, True)


def build():
    ellipsoid((0.0, 1.31, 0.0), (0.22, 0.29, 0.13), 1)  # torso on the spine
    ellipsoid((0.0, 1.75, 0.0), (0.11, 0.11, 0.11), 2)  # head
    for x, thigh, shin in ((0.11, 3, 4), (-0.11, 5, 6)):
        limb(x, 0.98, 0.53, 0.06, 0.07, 0.05, thigh, shin)
    for x, up, fore in ((0.30, 7, 8), (-0.30, 9, 10)):
        limb(x, 1.50, 1.23, 0.96, 0.05, 0.04, up, fore, n_rings=22, n_around=10)


def signed_volume():
    s = 0.0
    for a, b, c in F:
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = V[a], V[b], V[c]
        s += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
    return s / 6


def quat_x(a):
    return (math.sin(a / 2), 0.0, 0.0, math.cos(a / 2))


def walk(t):
    """Per joint: its rotation (about x, rad) at time t in [0, 1] (one cycle)."""
    ph = 2 * math.pi * t
    thigh_l = -0.45 * math.sin(ph)  # negative: the foot forward (+z)
    thigh_r = -thigh_l
    # A knee flexes (positive: the foot back) while its leg swings forward.
    knee_l = 0.15 + 0.45 * max(0.0, math.sin(ph + 0.6))
    knee_r = 0.15 + 0.45 * max(0.0, math.sin(ph + math.pi + 0.6))
    return {3: thigh_l, 4: knee_l, 5: thigh_r, 6: knee_r,
            7: -0.7 * thigh_l, 8: -0.35, 9: -0.7 * thigh_r, 10: -0.35}


def main():
    build()
    if signed_volume() < 0:
        F[:] = [(a, c, b) for a, b, c in F]
    blob = bytearray()
    views, accessors = [], []

    def push(data, target=None):
        while len(blob) % 4:
            blob.append(0)
        off = len(blob)
        blob.extend(data)
        v = {"buffer": 0, "byteOffset": off, "byteLength": len(data)}
        if target:
            v["target"] = target
        views.append(v)
        return len(views) - 1

    def accessor(view, ctype, count, typ, **extra):
        accessors.append(dict(bufferView=view, componentType=ctype, count=count, type=typ, **extra))
        return len(accessors) - 1

    pos = accessor(push(b"".join(struct.pack("<3f", *p) for p in V), 34962), 5126, len(V), "VEC3",
                   min=[min(p[k] for p in V) for k in range(3)], max=[max(p[k] for p in V) for k in range(3)])
    joints, weights = bytearray(), bytearray()
    for jw in JW:
        js = [j for j, _ in jw] + [0] * (4 - len(jw))
        ws = [w for _, w in jw] + [0.0] * (4 - len(jw))
        joints += struct.pack("<4B", *js)
        weights += struct.pack("<4f", *ws)
    jo = accessor(push(bytes(joints), 34962), 5121, len(V), "VEC4")
    we = accessor(push(bytes(weights), 34962), 5126, len(V), "VEC4")
    idx = accessor(push(b"".join(struct.pack("<3H", *t) for t in F), 34963), 5123, 3 * len(F), "SCALAR")
    ibm = bytearray()
    for j in range(len(JOINTS)):
        x, y, z = bind_position(j)
        ibm += struct.pack("<16f", 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -x, -y, -z, 1)
    ibm_acc = accessor(push(bytes(ibm)), 5126, len(JOINTS), "MAT4")
    n_keys = 17
    times = [i / (n_keys - 1) for i in range(n_keys)]
    t_acc = accessor(push(b"".join(struct.pack("<f", t) for t in times)), 5126, n_keys, "SCALAR",
                     min=[0.0], max=[1.0])
    samplers, channels = [], []
    poses = [walk(t) for t in times]
    for j in sorted(poses[0]):
        out = b"".join(struct.pack("<4f", *quat_x(p[j])) for p in poses)
        samplers.append({"input": t_acc, "output": accessor(push(out), 5126, n_keys, "VEC4"),
                         "interpolation": "LINEAR"})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": j, "path": "rotation"}})
    bob = b"".join(struct.pack("<3f", 0.0, 1.0 + 0.02 * math.cos(4 * math.pi * t), 0.0) for t in times)
    samplers.append({"input": t_acc, "output": accessor(push(bob), 5126, n_keys, "VEC3"),
                     "interpolation": "LINEAR"})
    channels.append({"sampler": len(samplers) - 1, "target": {"node": 0, "path": "translation"}})

    nodes = []
    for j, (name, parent, t) in enumerate(JOINTS):
        n = {"name": name, "translation": list(t)}
        kids = [k for k, jj in enumerate(JOINTS) if jj[1] == j]
        if kids:
            n["children"] = kids
        nodes.append(n)
    nodes.append({"name": "walker", "mesh": 0, "skin": 0})
    doc = {
        "asset": {"version": "2.0", "generator": "lobefit scripts/walker.py"},
        "scene": 0,
        "scenes": [{"nodes": [0, len(JOINTS)]}],
        "nodes": nodes,
        "meshes": [{"name": "walker", "primitives": [{
            "attributes": {"POSITION": pos, "JOINTS_0": jo, "WEIGHTS_0": we}, "indices": idx}]}],
        "skins": [{"name": "walker", "inverseBindMatrices": ibm_acc, "skeleton": 0,
                   "joints": list(range(len(JOINTS)))}],
        "animations": [{"name": "walk", "samplers": samplers, "channels": channels}],
        "buffers": [{"byteLength": len(blob),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    path = sys.argv[1] if len(sys.argv) > 1 else "assets/meshes/walker.gltf"
    with open(path, "w") as f:
        json.dump(doc, f, separators=(",", ":"))
        f.write("\n")
    print(f"{path}: {len(V)} vertices, {len(F)} triangles, volume {abs(signed_volume()):.5f}")


if __name__ == "__main__":
    main()
