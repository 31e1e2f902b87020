#pragma once
// What a fast-path stack (stack.h) lacks of a stack reconstructed from a scan, emulated so that
// the CNN can train on stacks that look like scans (issue #22) without scanning each one:
// - each camera's pixel footprint: an observation is blurred in the top view by a Gaussian,
//   `along_px` in the direction of its camera's azimuth (where an oblique camera's footprint is
//   stretched) and `across_px` across it;
// - the radiometric calibration's error: a gain per observation, log-normal;
// - what is left (sensor noise through the HDR merge, and the reconstruction's misregistration):
//   noise with σ(L) = noise · √(L · m), m the observation's mean radiance, so that a pixel at the
//   mean has `noise` relative noise.
// MatchScanEmulation measures all of them on a pair of stacks of one material on one grid (the
// fast path, and the reconstruction of a scan), so the emulation is fitted to, and checked
// against, what loom's own scan and reconstruction do; the result is a small YAML file that
// `loom train --scan-emulation` reads.

#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/observation_stack.h"
#include "core/status.h"

namespace loom::sim {

inline constexpr int kScanEmulationSchemaVersion = 1;

struct CameraFootprint {
  std::string camera;
  double along_px = 0, across_px = 0;  // Gaussian σ, stack pixels
};

struct ScanEmulation {
  std::vector<CameraFootprint> footprints;  // one per camera of the stacks it degrades
  double gain_spread = 0;                   // σ of each observation's log gain
  double noise = 0;                         // relative noise at the observation's mean radiance
  Status Check() const;                     // every problem, naming the field
  nlohmann::json ToJson() const;
  std::string ToYaml() const;  // what LoadScanEmulation reads
};

Result<ScanEmulation> LoadScanEmulation(const std::filesystem::path& path);

// Degrades `stack`'s radiances in place; unseen (NaN) pixels stay unseen and do not leak into
// the blur. Deterministic in `seed`. An observation whose camera has no footprint is an error
// naming the camera (and `stack` is left as it was).
Status EmulateScan(const ScanEmulation& emulation, uint64_t seed, ObservationStack& stack);

// Per camera: its fitted footprint, and the reconstruction's distance from the fast path (RMS
// difference over RMS radiance, each observation at its best gain) before and after the blur.
struct FootprintFit {
  CameraFootprint footprint;
  double residual_unblurred = 0, residual_blurred = 0;
};

// The residual's RMS in bins of L / m (the radiance over the observation's mean), against what
// the fitted noise law predicts for the bin's pixels.
struct NoiseBin {
  double low = 0, high = 0;  // of L / m
  int64_t pixels = 0;
  double measured = 0, predicted = 0;  // RMS residual / m
};

struct ScanEmulationMatch {
  ScanEmulation emulation;
  // The gains' geometric mean: a reconstruction brighter or darker than the truth throughout (a
  // radiometric bias, which the emulation leaves out: it is for calibration to remove).
  double gain_mean = 1;
  std::vector<FootprintFit> cameras;
  std::vector<NoiseBin> noise_bins;
  // The check, medians over observations of an emulation of the fast path with the fitted values:
  // - its distance from the fast path over the reconstruction's (1: as far off as a scan);
  // - high-frequency energy (mean squared 4-neighbour Laplacian) of the fast path and of the
  //   emulation, each over the reconstruction's (1: as sharp as a scan).
  double distance_emulated = 0;
  double high_frequency_fast = 0, high_frequency_emulated = 0;
  nlohmann::json ToJson() const;
  void Report(std::ostream& out) const;
};

// `fast` and `reconstructed`: one material on one grid, with the same observations.
Result<ScanEmulationMatch> MatchScanEmulation(const ObservationStack& fast, const ObservationStack& reconstructed);

}  // namespace loom::sim
