#!/usr/bin/env bash
# The studies behind docs/ figures, at full size. They measure (times, errors against
# Monte Carlo) and check nothing, so CI does not run them; their code paths are
# exercised by the test suite at tiny sizes (tests/it/render_meunier.rs,
# tests/it/render_rigs.rs).
# Usage: bash scripts/studies.sh [OUT]   (default plots/; builds the release binary first)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-plots}
cargo build --release -q
bin=target/release/lobefit
run() { printf '\n== %s\n' "$*" >&2; "$@"; }
# Meunier: 1–1024 sphere blockers, lobes against Monte Carlo at equal error
# (docs/meunier.md, "Blocker scaling").
run $bin plot meunier-scaling --out "$out/meunier"
# The lobes alone per N on one thread: µs per pixel (median of 5), RMSE, image hash
# (docs/meunier.md, "The cost per pixel against the blocker count").
run cargo test -q -p lobefit-pipelines --lib study_meunier_lobes_scaling -- --ignored --nocapture
# Irradiance rigs: the 24-frame drive past the lamps (docs/rigs.md, "--scene drive").
run $bin render rigs --scene drive --out "$out/rigs"
# Animations (docs/meshes.md, "Motion"): 24 frames at 160 × 120 of each built-in
# animation and of the walking bunny, with the reference and the strongest Monte Carlo
# at the method's time; frames, an animated PNG and a CSV each.
run $bin render isg --scene falling --frames 24 --width 160 --spp 1024 --out "$out/anim"
run $bin render meunier --scene orbit --frames 24 --width 160 --spp 1024 --out "$out/anim"
run $bin render isg --scene assets/meshes/isg-bunny-walk.json --frames 24 --width 160 --spp 256 --out "$out/anim"
run $bin render isg --scene assets/meshes/isg-bunny-nod.json --frames 24 --width 160 --spp 256 --out "$out/anim"
run $bin render shexp --scene swim --frames 24 --width 160 --spp 1024 --out "$out/anim"
# The skinned, walking mannequin (docs/meshes.md, "Skinned characters"): 24 frames in
# each shadow pipeline, and the still's proxy rows (sets against the triangles, on the
# mesh and off it).
for p in isg meunier shexp; do
  run $bin render $p --scene assets/meshes/$p-walker.json --frames 24 --width 160 --spp 256 --out "$out/anim"
  run $bin render $p --scene assets/meshes/$p-walker.json --width 160 --spp 1024 --out "$out/walker"
done
# SH exponentiation on the shipped scenes and on independent ones (spheres under the
# whale's sky over flat ground, written by scripts/shexp_scenes.py): its variants and the
# median error over the unoccluded radiance against SH-ideal's (docs/shexp-render.md,
# "Independent scenes"; ~5 min on 2 cores).
for sc in whale whale-diffuse wrecking assets/scenes/shexp-spheres{12,60}-{diffuse,phong3}.json; do
  run $bin render shexp --scene "$sc" --width 96 --spp 1024 --out "$out/shexp"
done
# HYB's rates and the blockers' per-band log factors re-fitted on the 12-sphere scenes'
# summed logs against SH-ideal, then tested on the other five (docs/shexp-render.md,
# "HYB re-fitted on sums", "Per-blocker logs fitted on sums"; ~30 s).
run cargo test -q -p lobefit-pipelines --lib study_hyb_refit -- --ignored --nocapture
run cargo test -q -p lobefit-pipelines --lib study_blocker_bands -- --ignored --nocapture
# The direct-light study and the rigs' figures.
run $bin plot meunier --out "$out/meunier"
run $bin plot rigs --out "$out/rigs"
# Plain Monte Carlo, scrambled Sobol, Sobol with a control variate (SGs picked by their
# integral, or by their contribution at the point), adaptive sampling and the hybrid (the
# pipeline as control variate) against each pipeline's configurations at equal error,
# samples and time measured; per scene a summary JSON and a Pareto chart in
# docs/figures/baselines, then the Pareto fronts (docs/pipelines.md, "Stronger baselines";
# ~4 min on 2 cores). The dev profile: the workspace optimises it (opt-level 2); the flip
# feature adds ꟻLIP (nv-flip compiles NVIDIA's C++ with the machine's g++).
base="$(pwd)/docs/figures/baselines"
LF_OUT="$base" LF_SCENES=fig12,fig12-diffuse,whale,fig13 run cargo test -q -p lobefit-pipelines --features flip --lib study_baselines -- --ignored --nocapture
LF_OUT="$base" LF_WIDTH=16 LF_SCENES=wrecking run cargo test -q -p lobefit-pipelines --features flip --lib study_baselines -- --ignored --nocapture
LF_OUT="$base" LF_SCENES=cluster-1,cluster-16,cluster-256,cluster-1024,torus-1,torus-16,torus-252,torus-1020 \
  run cargo test -q -p lobefit-pipelines --features flip --lib study_baselines -- --ignored --nocapture
# The independent SH-exponentiation scenes (spheres under the whale's sky), with the
# exact-caps candidate among the configurations (docs/shexp-render.md).
LF_OUT="$base" LF_SCENES="$(pwd)/assets/scenes/shexp-spheres12-diffuse.json,$(pwd)/assets/scenes/shexp-spheres60-diffuse.json" \
  run cargo test -q -p lobefit-pipelines --features flip --lib study_baselines -- --ignored --nocapture
run python3 scripts/pareto_front.py "$base"
# The sphere proxy's error: the bunny shaded by the ISG pipeline with fitted sphere sets
# of 8–256 spheres per method against the reference with its true triangles, next to
# the pipeline's own error (docs/meshes.md; ~15 min on 2 cores at 4096 samples/pixel).
run cargo test -q -p lobefit-pipelines --lib isg::proxy::tests::proxy_error_study -- --ignored --nocapture
# The sphere hierarchy's level of detail: the ISG with the flat set against the
# hierarchy's cut at 1-20 degrees, on the 306-sphere sweep and the bunny with 256 and
# 1 024 optimize spheres (docs/meshes.md, "A sphere hierarchy"; ~1 min on 2 cores;
# LF_LOD=bunny-1024 runs one).
run cargo test -q --release -p lobefit-pipelines --lib isg::lod::tests::lod_study_full -- --ignored --nocapture
# The same hierarchy in SH exponentiation: the bunny over the whale's terrain, 1 024
# optimize spheres of overlap <= 1.2 (docs/meshes.md, "In SH exponentiation").
run cargo test -q --release -p lobefit-pipelines --lib shexp::tests::cut_study_full -- --ignored --nocapture
# Per-vertex shading against per-pixel: the bunny (64 optimize spheres) at 96 to 640
# pixels wide (docs/meshes.md, "Per-vertex shading"; ~1 min on 2 cores).
run cargo test -q --release -p lobefit-pipelines --lib isg::vertex::tests::vertex_study_full -- --ignored --nocapture
# The ISG's specular term under a map: eq. 9 with Γ_L against the lobes' forms, on the
# apartment and sky scenes with glossy spheres (docs/environment.md, "Eq. 9 with Γ_L";
# builds each map's Γ_L first; ~5 min on 2 cores).
run cargo test -q --release -p lobefit-pipelines --lib isg::eq9::tests::eq9_study_full -- --ignored --nocapture
# Issue 58's image measure under the three maps: |ISG − reference| over each pixel's
# unoccluded radiance (docs/environment.md, "Scenes lit by a map"; ~15 s).
run cargo test -q --release -p lobefit-pipelines --lib isg::eq9::target::unoccluded_target_study -- --ignored --nocapture
# Ashikhmin–Shirley as SG sums: 1, 3, 5, 7 SGs per view against quadrature of the term
# (docs/environment.md, "Ashikhmin–Shirley"; ~4 min on 2 cores).
run cargo test -q --release -p lobefit-pipelines --lib brdf_fit::tests::ashikhmin_shirley_study -- --ignored --nocapture
