#!/usr/bin/env bash
# Scores fits of a capture without ground truth by leaving views out: for each image k, `loom
# import --hold-out k` makes a stack of the other images and one of image k alone; each method
# fits the first (`loom fit`) and is scored on the second (`loom eval --stack`: the relative L1 of
# the image it never saw, re-rendered from its maps). Every fold's L1 is divided by the baseline's
# (BASELINE, default lambert: robust photometric stereo fitted to the same images).
#
#   scripts/leave-one-out.sh CAPTURE OUT [IMPORT OPTIONS...]
#       e.g. scripts/leave-one-out.sh my-flash-capture/ loo/ --downsample 8
#
# LOOM (default build/apps/loom) and METHODS (default "ceres refine") can be set in the
# environment; FIT_OPTIONS are passed to every `loom fit` but the baseline's. OUT/fold-K/ keeps each
# fold's stacks, fits and reports; OUT/scores.tsv has one line per fold and method (L1, and its
# ratio to the baseline's), and the last lines printed are each method's mean and worst ratio.
set -euo pipefail
cd "$(dirname "$0")/.."

if [[ $# -lt 2 ]]; then
  echo "usage: $0 CAPTURE OUT [IMPORT OPTIONS...]" >&2
  exit 2
fi
capture=$1
out=$2
shift 2
loom=${LOOM:-build/apps/loom}
baseline=${BASELINE:-lambert}
read -r -a methods <<< "${METHODS:-ceres refine}"
read -r -a fit_options <<< "${FIT_OPTIONS:-}"

# The held-out view's relative L1 from `loom eval`'s report.
held_out_l1() {  # MAPS HELD OUT
  "$loom" eval "$1" --stack "$2" --renderer-views 0 --out "$3" |
    sed -n 's/.*against the measured values.*:  all \([0-9.]*\).*/\1/p'
}

mkdir -p "$out"
images=$("$loom" import "$capture" "$@" --out "$out/all.exr" | sed -n 's/^imported \([0-9]*\) images.*/\1/p')
scores="$out/scores.tsv"
printf "fold\tmethod\theld_out_l1\tratio_to_%s\n" "$baseline" > "$scores"
for ((k = 0; k < images; ++k)); do
  fold="$out/fold-$k"
  rm -rf "$fold"
  mkdir -p "$fold"
  "$loom" import "$capture" "$@" --hold-out "$k" --held-out "$fold/held.exr" --out "$fold/train.exr" > "$fold/import.log"
  "$loom" fit "$fold/train.exr" --method "$baseline" --out "$fold/$baseline" --quiet > "$fold/$baseline.log"
  base=$(held_out_l1 "$fold/$baseline/svbrdf.exr" "$fold/held.exr" "$fold/$baseline-held")
  printf "%d\t%s\t%s\t1\n" "$k" "$baseline" "$base" >> "$scores"
  for method in "${methods[@]}"; do
    "$loom" fit "$fold/train.exr" --method "$method" "${fit_options[@]}" --out "$fold/$method" --quiet > "$fold/$method.log"
    l1=$(held_out_l1 "$fold/$method/svbrdf.exr" "$fold/held.exr" "$fold/$method-held")
    printf "%d\t%s\t%s\t%s\n" "$k" "$method" "$l1" "$(awk -v a="$l1" -v b="$base" 'BEGIN { printf "%.4f", a / b }')" >> "$scores"
  done
  echo "fold $k: $(awk -F'\t' -v k="$k" '$1 == k { printf "%s %s (%s×)  ", $2, $3, $4 }' "$scores")"
done
awk -F'\t' 'NR > 1 { n[$2]++; l1[$2] += $3; r[$2] += $4; if ($4 > worst[$2]) worst[$2] = $4 }
  END { for (m in n) printf "%s: mean held-out L1 %.4f, mean ratio %.3f×, worst %.3f× (%d folds)\n", m, l1[m] / n[m], r[m] / n[m], worst[m], n[m] }' \
  "$scores" | sort
