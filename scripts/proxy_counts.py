#!/usr/bin/env python3
"""The sphere proxy's error against sphere count in the Meunier and SH-exponentiation
renders (docs/meshes.md, "Proxy error against sphere count"): the bunny scenes
(assets/meshes/meunier-bunny.json, shexp-bunny.json) with their sphere set fitted at
8 ... 256 spheres by kmeans and kmeans-moment, each rendered by `lobefit render` at a
small size; prints the breakdown's "sphere sets → true meshes" row and the image's
relative RMSE. A study, not a check: CI does not run it.
Usage: python3 scripts/proxy_counts.py [WIDTH] [SPP] [PIPELINE ...]   (default 64 256
meunier shexp; release build)
       python3 scripts/proxy_counts.py --plot TABLE.txt OUT.png   (the printed table as a
chart: proxy row and image error against sphere count, log-log; needs matplotlib)"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile



def plot(table, png):
    """Draws the table this script prints: per pipeline and fit method, the proxy row
    (solid) and the image's relative RMSE (dashed) against the sphere count; a refused
    render is an x on the axis' top edge."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = [line.split() for line in open(table).read().splitlines()[1:] if line.strip()]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    for ax, pipeline in zip(axes, ["meunier", "shexp"]):
        for method, colour, top in [("kmeans", "tab:blue", 0.42), ("kmeans-moment", "tab:orange", 0.48)]:
            ok = [(int(r[2]), float(r[3]), float(r[4])) for r in rows
                  if r[0] == pipeline and r[1] == method and r[3] != "refused:"]
            refused = [int(r[2]) for r in rows if r[0] == pipeline and r[1] == method and r[3] == "refused:"]
            if ok:
                n, proxy, image = zip(*ok)
                ax.plot(n, proxy, "o-", color=colour, label=f"{method}: proxy row")
                ax.plot(n, image, "s--", color=colour, alpha=0.6, label=f"{method}: image")
            for k in refused:
                ax.plot([k], [top], "x", color=colour, markersize=10, clip_on=False,
                        label=f"{method}: refused (exp* out of range)" if k == refused[0] else None)
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_ylim(0.03, 0.5)
        ax.set_title({"meunier": "Meunier (mask lobes)", "shexp": "SH exponentiation (order 4)"}[pipeline])
        ax.set_xlabel("spheres in the bunny's set")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="lower left" if pipeline == "meunier" else "upper left")
    axes[0].set_ylabel("relative RMSE (of the mean)")
    fig.suptitle("The sphere proxy's error against sphere count (bunny, 64 px, 256 spp)")
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    print(png)


if sys.argv[1:2] == ["--plot"]:
    plot(sys.argv[2], sys.argv[3])
    sys.exit(0)

width, spp = (sys.argv[1:] + ["64", "256"])[:2]
root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
lobefit = os.path.join(root, "target", "release", "lobefit")
with tempfile.TemporaryDirectory() as d:
    shutil.copy(os.path.join(root, "assets", "meshes", "bunny.obj"), d)
    print("pipeline method spheres proxy_rms image_rel_rmse")
    pipelines = sys.argv[3:] or ["meunier", "shexp"]
    for pipeline in pipelines:
        scene = json.load(open(os.path.join(root, "assets", "meshes", f"{pipeline}-bunny.json")))
        for method in ["kmeans", "kmeans-moment"]:
            for count in [8, 16, 32, 64, 128, 256]:
                scene["meshes"][0]["spheres"] = {"count": count, "method": method, "seed": 1}
                path = os.path.join(d, f"{pipeline}-bunny.json")
                json.dump(scene, open(path, "w"))
                run = subprocess.run([lobefit, "render", pipeline, "--scene", path, "--width", width,
                                      "--spp", spp, "--out", os.path.join(d, "out")],
                                     capture_output=True, text=True)
                if run.returncode != 0:
                    # A refusal is a result (SH exponentiation leaves its range under
                    # many overlapping spheres): print it and go on.
                    print(pipeline, method, count, "refused:", run.stderr.strip().splitlines()[-1], flush=True)
                    continue
                out = run.stdout
                proxy = re.search(r"sphere sets → true meshes[^:]*: RMS ([0-9.]+)", out).group(1)
                image = re.search(r"relative RMSE ([0-9.]+) against", out.splitlines()[-1]).group(1)
                print(pipeline, method, count, proxy, image, flush=True)
