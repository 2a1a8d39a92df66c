#!/usr/bin/env python3
"""The sphere proxy's error against sphere count in the Meunier and SH-exponentiation
renders (docs/meshes.md, "Proxy error against sphere count"): the bunny scenes
(assets/meshes/meunier-bunny.json, shexp-bunny.json) with their sphere set fitted at
8 ... 256 spheres by kmeans and kmeans-moment, each rendered by `lobefit render` at a
small size; prints the breakdown's "sphere sets → true meshes" row and the image's
relative RMSE. A study, not a check: CI does not run it.
Usage: python3 scripts/proxy_counts.py [WIDTH] [SPP] [PIPELINE ...]   (default 64 256
meunier shexp; release build)"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

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
