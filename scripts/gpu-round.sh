#!/bin/bash
# One fine-tuning round of a shipped CNN on a lent GPU machine, in one command
# (docs/gpu-training.md, "A round on a lent machine"):
#
#   bash scripts/gpu-round.sh fetch   # here, once: the GPU build's Debian packages into
#                                     # .gpu-deps/ (ignored, about 18 MB), which the device call carries
#   bash scripts/gpu-round.sh run     # there, as the device call's command (carry: .gpu-deps)
#
# `run` unpacks the packages, builds the GPU build's loom against PyTorch's CUDA LibTorch,
# fits a paper-size material (bench),
# trains 3 short epochs first (the check that a run outlives its second epoch's checkpoint: the
# crash docs/gpu-training.md describes must stay fixed), checks that the GPU computes the CPU's
# losses (same_losses), renders FABRICS fresh fabrics on every core, and fine-tunes
# the rig's shipped model on them with the chain's recipe (configs/models/<rig>/README.md),
# for as many steps as the short run's rate fits into TRAIN_S seconds. $OUT gets the logs and the
# model (float16 weights: what comes back from the machine is at most 16 MiB a file).
#
# Settings (environment): RIG (tac7-mini or tac7), FABRICS (1200; tac7 600), FIRST_SEED (60000: no run has trained
# on seeds from there), TRAIN_S (240), EPOCHS (4), TILES (16 a step), SEED (30), LR_START (3e-5),
# LR_END (5e-6), WIDTH (a width divisor below the model's widens it; default: the model's),
# DEVICE (cuda; cpu for a dry run), LOOM (a built loom: no build), OUT (required for run),
# BENCH (1: fit a paper-size material first, where the build has `fit`; 0: no), BENCH_SIZE (630),
# BENCH_ONLY (1: the build and the fits alone).
set -euo pipefail
cd "$(dirname "$0")/.."

readonly deps_dir=.gpu-deps
# The GPU build's Debian 12 packages that the machine's image lacks: headers, and the libraries
# with what they load (Ceres' SuiteSparse and ATLAS, OpenCV core's TBB and GLX).
readonly deps=(libopenexr-dev libopenexr-3-1-30 libimath-dev libimath-3-1-29 libyaml-cpp-dev libyaml-cpp0.7
  libcli11-dev nlohmann-json3-dev libeigen3-dev libpng-dev libpng16-16
  libceres-dev libceres3 libgoogle-glog-dev libgoogle-glog0v6 libgflags-dev libgflags2.2 libunwind8
  libcholmod3 libspqr2 libcxsparse3 libamd2 libcamd2 libccolamd2 libcolamd2 libsuitesparseconfig5 libmetis5
  libatlas3-base libgfortran5 libquadmath0
  libopencv-core-dev libopencv-core406 libopencv-imgproc-dev libopencv-imgproc406 libtbb12
  libglx0 libglvnd0 libx11-6 libx11-data libxcb1 libxau6 libxdmcp6 libbsd0 libmd0)

fetch() {
  mkdir -p "$deps_dir"
  (cd "$deps_dir" && apt-get download "${deps[@]}")
  ls -l "$deps_dir"
}

build() {
  local prefix=/tmp/gpu-deps
  for deb in "$deps_dir"/*.deb; do dpkg -x "$deb" "$prefix"; done
  # ATLAS keeps its BLAS and LAPACK in a folder of their own (Debian picks one by alternatives,
  # which unpacking does not run).
  local libs=$prefix/usr/lib/x86_64-linux-gnu
  export CMAKE_PREFIX_PATH="$prefix/usr" LD_LIBRARY_PATH="$libs:$libs/atlas${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
  scripts/build-gpu.sh
}

# The rig's chain recipe (configs/models/<rig>/README.md and HISTORY.md): what the network
# reads, and the seeded fabrics (some trained on, the validation and test ones) beside which the fresh ones are linked in as add-*.
recipe() {
  case $rig in
    tac7-mini)
      input=(--preset low)
      seeded=(--materials 36 --first-seed 4764 --validation 16 --test 16)
      fresh_share=0.25 default_fabrics=1200
      ;;
    tac7)
      # shellcheck disable=SC2054 # the commas are loom train's list of presets
      input=(--preset low,medium --input-layout paper)
      seeded=(--materials 28 --first-seed 13812 --validation 12 --test 12)
      fresh_share=0.5 default_fabrics=600
      ;;
    *)
      echo "error: RIG $rig: no chain recipe (tac7-mini or tac7)" >&2
      exit 2
      ;;
  esac
}

train() {
  local out=$1 epochs=$2 steps=$3
  shift 3
  "$loom" train --rig "configs/rig/$rig.yaml" "${input[@]}" "${seeded[@]}" --out "$out" --data "$data" \
    --init "$model" --out-of-model-share 0.5 --scan-like-share 0.5 --scan-emulation "$model/scan-emulation.yaml" \
    --size 32 --epochs "$epochs" --steps-per-epoch "$steps" --tiles-per-step "$tiles" --lr-start "$lr_start" \
    --lr-end "$lr_end" --weight-decay 0 --rerender-weight 10 --rerender-lobe-reference 0.1 --device "$device" \
    --threads 0 --seed "$seed" --quiet "$@"
}

# FABRICS fresh fabrics through loom train's dataset step, with one throwaway step, as the chain's
# rounds rendered theirs.
render_fresh() {
  local fresh=$1
  "$loom" train --rig "configs/rig/$rig.yaml" "${input[@]}" --out /tmp/gpu-round-throwaway --data "$fresh" \
    --init "$model" --materials "$fabrics" --first-seed "$first_seed" --out-of-model-share "$fresh_share" \
    --scan-like-share "$fresh_share" --scan-emulation "$model/scan-emulation.yaml" --validation 1 --test 1 \
    --size 32 --epochs 1 --steps-per-epoch 1 --tiles-per-step 1 --device "$device" --threads 0 --quiet
}

link_fresh() {
  local fresh=$1 data=$2
  mkdir -p "$data"
  for f in "$fresh"/*.exr; do ln -sf "$(realpath "$f")" "$data/add-$(basename "$f")"; done
}

# Runs a stage's command with the GPU's utilisation sampled each second (nvidia-smi dmon: the
# streaming multiprocessors' and memory's busy %) into $OUT/STAGE.dmon, and appends its mean and
# peak to $OUT/round.log; without nvidia-smi (a dry run on a CPU) the command runs alone.
with_utilisation() {
  local stage=$1
  shift
  if ! command -v nvidia-smi > /dev/null; then
    "$@"
    return
  fi
  nvidia-smi dmon -s u -d 1 > "$OUT/$stage.dmon" 2>&1 &
  local sampler=$!
  local status=0
  "$@" || status=$?
  kill "$sampler" 2> /dev/null || true
  wait "$sampler" 2> /dev/null || true
  python3 - "$OUT/$stage.dmon" "$stage" <<'PY' | tee -a "$OUT/round.log"
import sys
rows = [line.split() for line in open(sys.argv[1]) if line.strip() and not line.startswith("#")]
sm = [float(r[1]) for r in rows if len(r) > 2 and r[1].replace(".", "").isdigit()]
if sm:
    print(f"{sys.argv[2]}: GPU multiprocessors busy {sum(sm) / len(sm):.0f} % on average, {max(sm):.0f} % at most ({len(sm)} s sampled)")
else:
    print(f"{sys.argv[2]}: nvidia-smi dmon gave no samples")
PY
  return $status
}

# The paper's headline on this machine: a BENCH_SIZE² (630) tac7 low-preset fast-path material
# (728 observations: the paper's input layout's 932 channels) fitted by the CNN alone and by CNN +
# refine, the network on DEVICE and the refiner on every core; wall times, the CNN's own seconds
# (fit.json's cnn_seconds) and the GPU's utilisation to round.log.
bench() {
  local size=${BENCH_SIZE:-630} stack=$work/bench/stack.exr start
  mkdir -p "$work/bench"
  start=$SECONDS
  "$loom" sim render --rig configs/rig/tac7.yaml --stack --preset low --size "$size" --out "$stack" > "$OUT/bench.log" 2>&1
  echo "bench: rendered a ${size}² tac7 low-preset stack: $((SECONDS - start)) s" | tee -a "$OUT/round.log"
  local method
  for method in cnn cnn+refine; do
    start=$SECONDS
    with_utilisation "bench-$method" "$loom" fit "$stack" --method "$method" --device "$device" --threads 0 --quiet \
      --out "$work/bench/$method" >> "$OUT/bench.log" 2>&1
    echo "bench: ${size}² $method on $device: $((SECONDS - start)) s wall, the CNN $(python3 -c \
      'import json, sys; print(round(json.load(open(sys.argv[1]))["cnn_seconds"], 2))' "$work/bench/$method/fit.json") s" |
      tee -a "$OUT/round.log"
  done
}

# One code path on every device (fitting/cnn/torch/cnn_trainer.cc): 4 steps of a fresh network
# without dropout (whose masks each device draws with its own generator, as it does the radiance
# noise, off here too) on the seeded fabrics, on the CPU and on DEVICE from one seed; their
# epoch's losses must agree to float rounding (0.1 %), or the stage fails. Skipped on a CPU dry run.
same_losses() {
  [ "$device" = cpu ] && return
  local on
  for on in cpu "$device"; do
    "$loom" train --rig "configs/rig/$rig.yaml" "${input[@]}" "${seeded[@]}" --out "$work/same-$on" --data "$data" \
      --out-of-model-share 0.5 --scan-like-share 0.5 --scan-emulation "$model/scan-emulation.yaml" \
      --size 32 --epochs 1 --steps-per-epoch 4 --tiles-per-step 4 --dropout 0 --rerender-weight 10 \
      --rerender-lobe-reference 0.1 --device "$on" --threads 0 --seed 7 --quiet > "$OUT/same-$on.log" 2>&1
  done
  python3 - "$work/same-cpu/training.json" "$work/same-$device/training.json" <<'PY' | tee -a "$OUT/round.log"
import json, sys
cpu, gpu = (json.load(open(f))["epochs"][0] for f in sys.argv[1:])
worst = max(abs(gpu[k] - cpu[k]) / max(abs(cpu[k]), 1e-12) for k in ("train_loss", "train_rerender_loss", "validation_loss"))
print(f"same losses, cpu against the gpu: train {cpu['train_loss']:.6g} / {gpu['train_loss']:.6g}, re-rendering "
      f"{cpu['train_rerender_loss']:.6g} / {gpu['train_rerender_loss']:.6g}; worst relative difference {worst:.2e}")
sys.exit(0 if worst <= 1e-3 else 1)
PY
}

# Samples a second in the short run's last epoch.
rate_of() {
  python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["epochs"][-1]["samples_per_second"])' "$1/training.json"
}

run() {
  : "${OUT:?set OUT to the folder that comes back}"
  rig=${RIG:-tac7-mini}
  recipe
  model=configs/models/$rig fabrics=${FABRICS:-$default_fabrics} first_seed=${FIRST_SEED:-60000}
  tiles=${TILES:-16} seed=${SEED:-30} device=${DEVICE:-cuda} lr_start=${LR_START:-3e-5} lr_end=${LR_END:-5e-6}
  local epochs=${EPOCHS:-4} train_s=${TRAIN_S:-240} work=/tmp/gpu-round
  data=$work/data
  local widen=()
  [ -n "${WIDTH:-}" ] && widen=(--width-divisor "$WIDTH")
  rm -rf "$work" /tmp/gpu-round-throwaway
  mkdir -p "$OUT" "$data"
  # Each stage logs to its own file in $OUT; a failing one shows its end where the call's output does.
  trap 'echo "error: a stage failed; the end of its logs:" >&2; tail -n 15 "$OUT"/*.log >&2 2> /dev/null' ERR
  if [ -n "${LOOM:-}" ]; then
    loom=$LOOM
  else
    if ! compgen -G "$deps_dir/*.deb" > /dev/null; then
      echo "error: no $deps_dir/*.deb: run '$0 fetch' where apt reaches Debian, and carry $deps_dir" >&2
      exit 2
    fi
    build > "$OUT/build.log" 2>&1
    loom=build-gpu/apps/loom
  fi
  "$loom" version | tee "$OUT/version.txt"
  [ "${BENCH:-1}" = 1 ] && bench
  [ "${BENCH_ONLY:-0}" = 1 ] && return

  local start=$SECONDS
  with_utilisation short train "$work/short" 3 5 "${widen[@]}" > "$OUT/short.log" 2>&1
  local rate
  rate=$(rate_of "$work/short")
  echo "3 epochs of 5 steps (the seeded fabrics rendered first): $((SECONDS - start)) s, the last at $rate samples/s" |
    tee -a "$OUT/round.log"
  same_losses

  start=$SECONDS
  with_utilisation render render_fresh "$work/fresh" > "$OUT/render.log" 2>&1
  link_fresh "$work/fresh" "$data"
  echo "rendered $fabrics fabrics from seed $first_seed: $((SECONDS - start)) s" | tee -a "$OUT/round.log"

  local steps
  # A tile is 32² samples (loom train's default --tile).
  steps=$(python3 -c "import sys; r, t, e, k = map(float, sys.argv[1:]); print(max(1, int(r * t / (k * 1024) / e)))" \
    "$rate" "$train_s" "$epochs" "$tiles")
  start=$SECONDS
  with_utilisation train train "$work/model" "$epochs" "$steps" --weights float16 "${widen[@]}" > "$OUT/train.log" 2>&1
  echo "$epochs epochs of $steps steps ($tiles tiles of 32² each): $((SECONDS - start)) s, the last at $(rate_of "$work/model") samples/s" |
    tee -a "$OUT/round.log"
  cp "$work/model/model.json" "$work/model/weights.pt" "$work/model/training.json" "$OUT/"
}

case "${1:-}" in
  fetch) fetch ;;
  run) run ;;
  *)
    echo "usage: $0 fetch|run (see the comment at its top)" >&2
    exit 2
    ;;
esac
