#!/usr/bin/env bash
# Fit a database of stored scans on a SLURM cluster, one scan per array task:
# reconstruct (with the rig's calibration) → fit → evaluate (re-render error, HTML report).
#
#   ls -d /data/scans/*/ > scans.txt
#   sbatch --array=1-$(wc -l < scans.txt)%50 scripts/slurm-fit-array.sh scans.txt /data/calib /data/results
#
# Task N takes line N of SCANS (a scan directory) and writes RESULTS/<scan name>/{reconstruction,
# fit,report}. CALIB_DIR is a calibration directory (loom calibrate), or `nominal` for the rig
# YAML's own model. A task whose fit.json already exists is skipped, so resubmitting the same
# array after failures redoes only what failed. LOOM (default: loom on PATH), LOOM_FIT_METHOD
# (default: loom fit's own, the recommended method for the stack) and LOOM_RECONSTRUCT_ARGS (extra reconstruct options, e.g. "--size 256")
# can be set in the environment; the model is the rig's default (configs/models/<rig>) unless
# LOOM_MODEL names one. tests: scripts/testing/slurm_fit_array_test.sh runs it under a real,
# single-node Slurm.
#SBATCH --job-name=loom-fit
#SBATCH --cpus-per-task=8
#SBATCH --mem=16G
#SBATCH --time=04:00:00
#SBATCH --output=loom-fit-%A_%a.log
set -euo pipefail

if [[ $# -ne 3 ]]; then
  echo "usage: sbatch --array=1-N $0 SCANS.txt CALIB_DIR RESULTS_DIR" >&2
  exit 2
fi
scans=$1 calib=$2 results=$3
task=${SLURM_ARRAY_TASK_ID:?"not an array task: submit with sbatch --array=1-N"}
loom=${LOOM:-loom}
method=${LOOM_FIT_METHOD:-}
threads=${SLURM_CPUS_PER_TASK:-0}

scan=$(sed -n "${task}p" "$scans")
if [[ -z "$scan" ]]; then
  echo "error: $scans has no line $task" >&2
  exit 1
fi
name=$(basename "${scan%/}")
out="$results/$name"
if [[ -f "$out/fit/fit.json" ]]; then
  echo "$name: already fitted ($out/fit/fit.json), skipped"
  exit 0
fi
mkdir -p "$out"
echo "$name: task $task on $(hostname), $threads threads, method ${method:-the recommended one}"
# What an earlier, failed attempt at this task left (loom never writes into a non-empty --out).
rm -rf "$out/reconstruction" "$out/report"
calib_option=(--calib "$calib")
if [[ "$calib" == nominal ]]; then calib_option=(); fi
read -r -a reconstruct_args <<< "${LOOM_RECONSTRUCT_ARGS:-}"
"$loom" reconstruct "$scan" "${calib_option[@]}" "${reconstruct_args[@]}" --out "$out/reconstruction" \
  --threads "$threads" --quiet
fit_options=()
if [[ -n "$method" ]]; then fit_options=(--method "$method"); fi
if [[ -n "${LOOM_MODEL:-}" ]]; then fit_options+=(--model "$LOOM_MODEL"); fi
# loom fit writes under a partial name and renames its directory when complete: fit/fit.json
# marks a finished task.
"$loom" fit "$out/reconstruction/stack.exr" "${fit_options[@]}" --threads "$threads" \
  --out "$out/fit" --quiet
method=$(sed -n 's/^ *"method": "\([^"]*\)".*/\1/p' "$out/fit/fit.json")
"$loom" eval "$out/fit/svbrdf.exr" --stack "$out/reconstruction/stack.exr" --out "$out/report" --title "$name ($method)"
echo "$name: done → $out/report/index.html"
