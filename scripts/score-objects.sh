#!/bin/bash
# The simulated curved objects of docs/benchmarks.md ("Captures from other rigs"): each captured
# in the ps layout (96 × 96 px, 96 lights), imported, fitted with `lambert` and with the default
# (`ceres`), and scored against the true normals: mean, median, p90 angle and the tilt bands
# (10° each) where the default is worse than `lambert`.
#   bash scripts/score-objects.sh [LOOM] [OUT]     (defaults: build/apps/loom, score-objects/)
set -euo pipefail
loom=$(realpath "${1:-build/apps/loom}")
out=${2:-score-objects}
mkdir -p "$out" && cd "$out"

score() {
  local name=$1
  shift
  rm -rf "cap-$name" "fit-$name-"{lambert,ceres}* "eval-$name-"{lambert,ceres}
  "$loom" sim capture --size 96 --lights 96 "$@" --normals "normals-$name.exr" --out "cap-$name" > /dev/null
  "$loom" import "cap-$name" --scale 1 --out "stack-$name.exr" > /dev/null
  for method in lambert ceres; do
    "$loom" fit "stack-$name.exr" --method "$method" --out "fit-$name-$method" --quiet > "fit-$name-$method.log" 2>&1
    "$loom" eval "fit-$name-$method/svbrdf.exr" --stack "stack-$name.exr" --reference-normals "normals-$name.exr" \
      --renderer-views 0 --out "eval-$name-$method" > /dev/null
  done
  python3 - "$name" <<'PY'
import json, sys
name = sys.argv[1]
lam = json.load(open(f"eval-{name}-lambert/normals.json"))
fit = json.load(open(f"eval-{name}-ceres/normals.json"))
lights = json.load(open(f"fit-{name}-ceres/fit.json")).get("light_refinement") or {}
relit = f", lights turned {lights['mean_turn_deg']:.2f}°" if lights.get("applied") else ""
worse = [f"{10 * i}-{10 * i + 10}°: {f['mean_deg']:.2f} vs {l['mean_deg']:.2f}"
         for i, (f, l) in enumerate(zip(fit["by_tilt"], lam["by_tilt"])) if f.get("mean_deg", 0) > l.get("mean_deg", 0) + 0.005]
print(f"{name:22s} lambert {lam['mean_deg']:.2f}°  default {fit['mean_deg']:.2f}° (median {fit['median_deg']:.2f}°, "
      f"p90 {fit['p90_deg']:.2f}°{relit})  worse: {', '.join(worse) or 'none'}")
PY
}

score sphere-noise-free --noise 0
score sphere --noise 0.02
score sphere-broad-lobe --noise 0.02 --sigma 0.4
score cylinder --shape cylinder --noise 0.02
score out-of-model --noise 0.02 --out-of-model
score out-of-model-sharp --noise 0.01 --out-of-model --sigma 0.05 --specular 0.5
score out-of-model-shiny --noise 0.01 --out-of-model --sigma 0.1 --specular 0.8
# Each pixel integrated over its footprint (4 × 4 points), as a camera's is: the silhouette's pixels
# mix normals and the background; the truth stays the pixel centre's, as a benchmark's does.
score sphere-integrated --noise 0.02 --subpixels 4
score out-of-model-sharp-integrated --noise 0.01 --out-of-model --sigma 0.05 --specular 0.5 --subpixels 4
# The files' lights as a real dome's calibration errs (the images taken under the true ones).
miscalibrated="--light-error-deg 1.5 --intensity-error 0.03"
score sphere-miscal --noise 0.02 $miscalibrated
score broad-lobe-miscal --noise 0.02 --sigma 0.4 $miscalibrated
score out-of-model-miscal --noise 0.02 --out-of-model $miscalibrated
