#!/usr/bin/env python3
"""Prints, per scene, the Pareto front of error against time per pixel from the
baselines study's summaries (`<dir>/<scene>-summary.json`, written by
`study_baselines`; docs/pipelines.md): every measured point (each analytic
configuration, each estimator at each sample count) that no cheaper point beats
in error, in order of time, with who owns it. Usage: pareto_front.py DIR"""
import json
import pathlib
import sys


def points(summary):
    for m in summary["methods"]:
        yield m["us_per_pixel"], m["rel_rmse_noise_free"], m["name"]
    for e in summary["estimators"]:
        for p in e["curve"]:
            yield p["us_per_pixel"], p["rel_rmse_noise_free"], f'{e["name"]} {p["spp"]} spp'


def main():
    d = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "target/baselines")
    files = sorted(d.glob("*-summary.json"))
    if not files:
        sys.exit(f"no *-summary.json in {d}")
    for f in files:
        s = json.loads(f.read_text())
        front, best = [], float("inf")
        for us, err, who in sorted(points(s)):
            if 0 < err < best:
                front.append((us, err, who))
                best = err
        print(f'{s["scene"]} ({s["pixels"]} px):')
        for us, err, who in front:
            print(f"  {us:9.1f} µs/px  rel RMSE {err:.4f}  {who}")


if __name__ == "__main__":
    main()
