#!/usr/bin/env bash
# Scores the fitting methods on held-out simulated fabrics, as issue #7's targets ask: for each
# seed, the simulator's noise-free fast-path stack of a preset's plan (`loom sim render --stack
# --truth`), fitted by every method (`loom fit`) and evaluated against the ground truth (`loom
# eval`); then per method the mean re-render L1 against the measured values and its ratio to
# Ceres alone's, the mean shading-normal error, the mean a_d NRMSE and the mean of the fabrics'
# median anisotropy-angle errors (where the truth's lobe is anisotropic; `loom eval`).
#
#   scripts/score-methods.sh OUT [SEEDS...]      (default seeds: 1984-1999, those the shipped
#                                                 tac7-mini model held out as its test set)
#
# Each stack is the centre SIZE × SIZE px of the rig's sample made of that fabric (`sim render
# --stack --size`), not the training dataset's SIZE px material of the same seed.
# KIND (default fabric) picks the set: `fabric` (GD10 materials, which Ceres inverts exactly when
# noise-free) or `fabric-out-of-model` (the same fabrics with what GD10 cannot represent: a second
# lobe, coloured specular, fibre masking, sub-pixel mesostructure; sim/fabric.h).
# CALIB (a calibration directory from `loom calibrate`, e.g. a `loom demo`'s OUT/calib) scores
# reconstructed stacks instead: each fabric scanned on the simulated rig (`loom scan`, about a
# minute each on tac7-mini) and reconstructed with that calibration (`loom reconstruct --calib`),
# with the camera blur, noise and calibration error that the fast path leaves out.
# SCAN_EMULATION (a `loom sim match-scan` file, e.g. configs/models/tac7/scan-emulation.yaml)
# scores scan-like stacks instead, without a scan: the fast path degraded as that rig's scans
# were measured to be (`sim render --stack --scan-emulation`, its gains and noise seeded by the
# fabric's seed), for rigs whose scans take minutes per fabric.
#
# LOOM (default build/apps/loom), RIG (configs/rig/tac7-mini.yaml), PRESET (low), MODEL (the
# rig's default), SIZE (32 px), METHODS (ceres cnn cnn+ceres cnn+refine; ceres must be among them) can be
# set in the environment. OUT/<seed>/<method>/ keeps every fit and report; OUT/scores.tsv has
# one line per seed and method.
set -euo pipefail
cd "$(dirname "$0")/.."

if [[ $# -lt 1 ]]; then
  echo "usage: $0 OUT [SEEDS...]" >&2
  exit 2
fi
out=$1
shift
seeds=("$@")
if [[ ${#seeds[@]} -eq 0 ]]; then seeds=($(seq 1984 1999)); fi
loom=${LOOM:-build/apps/loom}
rig=${RIG:-configs/rig/tac7-mini.yaml}
preset=${PRESET:-low}
size=${SIZE:-32}
kind=${KIND:-fabric}
read -r -a methods <<< "${METHODS:-ceres cnn cnn+ceres cnn+refine}"
model_option=()
if [[ -n "${MODEL:-}" ]]; then model_option=(--model "$MODEL"); fi
if [[ -n "${CALIB:-}" && -n "${SCAN_EMULATION:-}" ]]; then
  echo "error: CALIB (reconstructed stacks) and SCAN_EMULATION (scan-like stacks) pick different sets: set one" >&2
  exit 2
fi

mkdir -p "$out"
scores="$out/scores.tsv"
printf "seed\tmethod\trerender_l1\tnormal_median_deg\ta_d_nrmse\talpha_median_deg\n" > "$scores"
for seed in "${seeds[@]}"; do
  dir="$out/$seed"
  mkdir -p "$dir"
  emulation_option=()
  if [[ -n "${SCAN_EMULATION:-}" ]]; then emulation_option=(--scan-emulation "$SCAN_EMULATION" --seed "$seed"); fi
  "$loom" sim render --rig "$rig" --stack --preset "$preset" --object "$kind:$seed" --size "$size" \
    "${emulation_option[@]}" --truth "$dir/truth.exr" --out "$dir/stack.exr" > /dev/null
  if [[ -n "${CALIB:-}" ]]; then
    rm -rf "$dir/scan" "$dir/reconstruction"
    "$loom" scan --rig "$rig" --preset "$preset" --object "$kind:$seed" --out "$dir/scan" --quiet > /dev/null
    "$loom" reconstruct "$dir/scan" --calib "$CALIB" --size "$size" --out "$dir/reconstruction" --quiet > /dev/null
    cp "$dir/reconstruction/stack.exr" "$dir/stack.exr"  # the truth stays the fast path's: same grid
  fi
  for method in "${methods[@]}"; do
    rm -rf "${dir:?}/$method"  # an earlier run's (loom never writes into a non-empty --out)
    "$loom" fit "$dir/stack.exr" --method "$method" "${model_option[@]}" --out "$dir/$method/fit" --quiet > /dev/null
    report=$("$loom" eval "$dir/$method/fit/svbrdf.exr" --stack "$dir/stack.exr" --reference "$dir/truth.exr" \
      --out "$dir/$method/report")
    # eval prints "… a_d 0.0024 …", "shading normal error: median 0.23 deg, …" and "… all 0.0038 / …".
    l1=$(sed -n 's/.*against the measured values.*:  all \([0-9.]*\).*/\1/p' <<< "$report")
    normal=$(sed -n 's/^shading normal error: median \([0-9.]*\) deg.*/\1/p' <<< "$report")
    a_d=$(sed -n 's/.*NRMSE against the reference:  a_d \([0-9.]*\).*/\1/p' <<< "$report")
    # "… angle off by median 6.3 deg …": only where the truth has anisotropic lobes, else nan
    # (left out of the method's mean, which is over the fabrics that have them).
    alpha=$(sed -n 's/.*angle off by median \([0-9.]*\) deg.*/\1/p' <<< "$report")
    if [[ -z "$l1" || -z "$normal" || -z "$a_d" ]]; then
      echo "error: could not read the scores of $kind:$seed ($method) from loom eval's output:" >&2
      echo "$report" >&2
      exit 1
    fi
    printf "%s\t%s\t%s\t%s\t%s\t%s\n" "$seed" "$method" "$l1" "$normal" "$a_d" "${alpha:-nan}" | tee -a "$scores"
  done
done

echo
echo "over ${#seeds[@]} ${kind}s (${size} px, preset $preset${CALIB:+, reconstructed with $CALIB}${SCAN_EMULATION:+, scan-like by $SCAN_EMULATION}): mean re-render L1 (ratio to ceres), normal median (deg), a_d NRMSE, alpha median (deg)"
awk -F'\t' 'NR > 1 { n[$2]++; l1[$2] += $3; normal[$2] += $4; ad[$2] += $5; if ($6 != "nan") { na[$2]++; alpha[$2] += $6 } }
  END {
    if (!("ceres" in n)) { print "error: METHODS has no ceres to compare with" > "/dev/stderr"; exit 1 }
    # The angle as text: printf %f of the string "nan" is nan in mawk but 0.0 in gawk.
    for (m in n) printf "%-10s L1 %.5f (%.3fx)  normal %.2f  a_d %.4f  alpha %s\n", m, l1[m] / n[m], l1[m] / l1["ceres"],
                        normal[m] / n[m], ad[m] / n[m], na[m] ? sprintf("%.1f", alpha[m] / na[m]) : "nan"
  }' "$scores" | sort
