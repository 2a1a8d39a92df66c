#!/usr/bin/env python3
"""Makes assets/meshes/bunny.obj from the Stanford bunny (a public OBJ copy of the
Stanford 3D Scanning Repository's reconstruction, 35 947 vertices, 69 451 triangles):
its open boundary loops (the scan's holes in the base) are closed by a fan around each
loop's centroid, then the mesh is decimated by vertex clustering on a cubic grid of
cell `--cell` (each cell's vertices merged into their mean; collapsed and duplicate
triangles dropped). Pure Python, deterministic.

    python3 scripts/decimate-bunny.py stanford-bunny.obj assets/meshes/bunny.obj --cell 0.0027
"""
import argparse
import math
from collections import defaultdict


def read(path):
    vs, fs = [], []
    with open(path) as f:
        for line in f:
            p = line.split()
            if not p:
                continue
            if p[0] == "v":
                vs.append(tuple(float(x) for x in p[1:4]))
            elif p[0] == "f":
                idx = [int(t.split("/")[0]) - 1 for t in p[1:]]
                for k in range(1, len(idx) - 1):
                    fs.append((idx[0], idx[k], idx[k + 1]))
    return vs, fs


def close_holes(vs, fs):
    """Fans each boundary loop (directed edges without their twin) around its centroid."""
    directed = set()
    for a, b, c in fs:
        directed.update([(a, b), (b, c), (c, a)])
    # A boundary edge (a, b) has no (b, a); the fill triangle runs it backwards.
    nxt = {}
    for a, b in directed:
        if (b, a) not in directed:
            nxt[b] = a
    seen, loops = set(), []
    for start in sorted(nxt):
        if start in seen:
            continue
        loop, v = [], start
        while v not in seen and v in nxt:
            seen.add(v)
            loop.append(v)
            v = nxt[v]
        if len(loop) >= 3 and v == start:
            loops.append(loop)
    for loop in loops:
        c = tuple(sum(vs[i][k] for i in loop) / len(loop) for k in range(3))
        ci = len(vs)
        vs.append(c)
        for k in range(len(loop)):
            fs.append((loop[k], loop[(k + 1) % len(loop)], ci))
    return loops


def cluster(vs, fs, cell):
    key = [tuple(math.floor(x / cell) for x in v) for v in vs]
    ids, sums = {}, []
    rep = []
    for v, k in zip(vs, key):
        if k not in ids:
            ids[k] = len(sums)
            sums.append([0.0, 0.0, 0.0, 0])
        s = sums[ids[k]]
        s[0] += v[0]
        s[1] += v[1]
        s[2] += v[2]
        s[3] += 1
        rep.append(ids[k])
    out_f, seen = [], set()
    for a, b, c in fs:
        a, b, c = rep[a], rep[b], rep[c]
        if a == b or b == c or a == c:
            continue
        k = tuple(sorted((a, b, c)))
        if k in seen:
            continue
        seen.add(k)
        out_f.append((a, b, c))
    used = sorted({i for f in out_f for i in f})
    new = {o: n for n, o in enumerate(used)}
    out_v = [tuple(sums[i][k] / sums[i][3] for k in range(3)) for i in used]
    return out_v, [tuple(new[i] for i in f) for f in out_f]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("src")
    ap.add_argument("dst")
    ap.add_argument("--cell", type=float, default=0.0027)
    a = ap.parse_args()
    vs, fs = read(a.src)
    n0v, n0f = len(vs), len(fs)
    loops = close_holes(vs, fs)
    vs, fs = cluster(vs, fs, a.cell)
    with open(a.dst, "w") as f:
        f.write("# Stanford bunny (Stanford Computer Graphics Laboratory, Stanford 3D Scanning Repository),\n")
        f.write(f"# {n0v} vertices and {n0f} triangles; {len(loops)} boundary loops closed by centroid fans,\n")
        f.write(f"# decimated by vertex clustering (cell {a.cell}) by scripts/decimate-bunny.py.\n")
        for v in vs:
            f.write("v %.6f %.6f %.6f\n" % v)
        for t in fs:
            f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))
    print(f"{n0v} vertices, {n0f} triangles, {len(loops)} loops closed -> {len(vs)} vertices, {len(fs)} triangles")


if __name__ == "__main__":
    main()
