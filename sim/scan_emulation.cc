#include "sim/scan_emulation.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <map>
#include <sstream>

#include "core/check.h"
#include "core/config.h"
#include "core/output_file.h"
#include "core/parallel.h"
#include "sim/internal/noise.h"

namespace loom::sim {
namespace {

constexpr double kMaxFootprintPx = 4;
// Below this σ the Gaussian is a delta at the grid's resolution.
constexpr double kSharpPx = 0.05;
// The footprints MatchScanEmulation tries, in stack pixels.
constexpr double kFootprintStepPx = 0.1, kLargestTriedPx = 2;

// One observation's radiance plane.
struct Plane {
  int width = 0, height = 0;
  std::vector<double> values;  // NaN: unseen
  double at(int x, int y) const { return values[static_cast<size_t>(y) * width + x]; }
};

Plane ReadPlane(const ObservationStack& stack, int observation) {
  const Image& image = stack.image;
  Plane plane{image.width(), image.height(), {}};
  const auto channel = image.channel(ObservationStack::ObservationChannel(observation));
  plane.values.assign(channel.begin(), channel.end());
  return plane;
}

void WritePlane(const Plane& plane, int observation, ObservationStack& stack) {
  const auto channel = stack.image.channel(ObservationStack::ObservationChannel(observation));
  std::transform(plane.values.begin(), plane.values.end(), channel.begin(), [](double v) { return static_cast<float>(v); });
}

// The footprint's Gaussian in the top view, stretched along the camera's azimuth (seen from the
// sample; a camera straight above has none, and `along` then lies along x).
struct Kernel {
  int radius = 0;
  std::vector<double> weights;  // (2 radius + 1)², row-major
};

Kernel FootprintKernel(const CameraFootprint& footprint, const Eigen::Vector3d& camera_mm) {
  const Eigen::Vector2d horizontal = camera_mm.head<2>();
  const Eigen::Vector2d along = horizontal.norm() > 1e-6 * camera_mm.norm() ? horizontal.normalized() : Eigen::Vector2d::UnitX();
  const double s_along = std::max(footprint.along_px, kSharpPx), s_across = std::max(footprint.across_px, kSharpPx);
  Kernel kernel;
  kernel.radius = static_cast<int>(std::ceil(3 * std::max(footprint.along_px, footprint.across_px)));
  const int side = 2 * kernel.radius + 1;
  kernel.weights.resize(side * side);
  for (int dy = -kernel.radius; dy <= kernel.radius; ++dy) {
    for (int dx = -kernel.radius; dx <= kernel.radius; ++dx) {
      const double u = (dx * along.x() + dy * along.y()) / s_along, v = (-dx * along.y() + dy * along.x()) / s_across;
      kernel.weights[(dy + kernel.radius) * side + dx + kernel.radius] = std::exp(-0.5 * (u * u + v * v));
    }
  }
  return kernel;
}

// Normalised convolution: seen pixels blurred over their seen neighbours only.
Plane Blur(const Plane& plane, const Kernel& kernel) {
  if (kernel.radius == 0) return plane;
  const int side = 2 * kernel.radius + 1;
  Plane blurred = plane;
  for (int y = 0; y < plane.height; ++y) {
    for (int x = 0; x < plane.width; ++x) {
      if (!std::isfinite(plane.at(x, y))) continue;
      double sum = 0, weight = 0;
      for (int dy = -kernel.radius; dy <= kernel.radius; ++dy) {
        const int sy = y + dy;
        if (sy < 0 || sy >= plane.height) continue;
        for (int dx = -kernel.radius; dx <= kernel.radius; ++dx) {
          const int sx = x + dx;
          if (sx < 0 || sx >= plane.width || !std::isfinite(plane.at(sx, sy))) continue;
          const double w = kernel.weights[(dy + kernel.radius) * side + dx + kernel.radius];
          sum += w * plane.at(sx, sy), weight += w;
        }
      }
      blurred.values[static_cast<size_t>(y) * plane.width + x] = sum / weight;
    }
  }
  return blurred;
}

double MeanSeen(const Plane& plane) {
  double sum = 0;
  int64_t count = 0;
  for (double v : plane.values) {
    if (std::isfinite(v)) sum += v, ++count;
  }
  return count > 0 ? sum / count : 0;
}

// Mean squared 4-neighbour Laplacian where a pixel and its neighbours are seen.
double HighFrequencyEnergy(const Plane& plane) {
  double sum = 0;
  int64_t count = 0;
  for (int y = 1; y + 1 < plane.height; ++y) {
    for (int x = 1; x + 1 < plane.width; ++x) {
      const double laplacian =
          plane.at(x - 1, y) + plane.at(x + 1, y) + plane.at(x, y - 1) + plane.at(x, y + 1) - 4 * plane.at(x, y);
      if (std::isfinite(laplacian)) sum += laplacian * laplacian, ++count;
    }
  }
  return count > 0 ? sum / count : 0;
}

double Median(std::vector<double> values) {
  if (values.empty()) return NAN;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

// The least-squares gain of `model` onto `target` over the pixels seen in both, and the sums of
// the squared residual and of the squared target there.
struct GainFit {
  double gain = 1, residual_squares = 0, target_squares = 0;
};

GainFit FitGain(const Plane& model, const Plane& target) {
  double mt = 0, mm = 0, tt = 0;
  for (size_t i = 0; i < model.values.size(); ++i) {
    const double m = model.values[i], t = target.values[i];
    if (!std::isfinite(m) || !std::isfinite(t)) continue;
    mt += m * t, mm += m * m, tt += t * t;
  }
  GainFit fit;
  fit.gain = mm > 0 ? mt / mm : 1;
  fit.residual_squares = std::max(0.0, tt - mt * fit.gain);
  fit.target_squares = tt;
  return fit;
}

// The two stacks as planes, and which observations each camera made.
struct StackPair {
  const ObservationStack& fast;
  std::vector<Plane> fast_planes, target_planes;
  std::map<std::string, std::vector<int>> by_camera;
};

// Each of `observations` blurred with `footprint` and fitted to the reconstruction.
std::vector<GainFit> FitObservations(const StackPair& pair, const std::vector<int>& observations,
                                     const CameraFootprint& footprint) {
  std::vector<GainFit> fits(observations.size());
  ParallelFor(static_cast<int>(observations.size()), 0, [&](int i) {
    const int k = observations[i];
    const Kernel kernel = FootprintKernel(footprint, pair.fast.observations[k].camera_mm);
    fits[i] = FitGain(Blur(pair.fast_planes[k], kernel), pair.target_planes[k]);
  });
  return fits;
}

double RelativeResidual(const std::vector<GainFit>& fits) {
  double residual = 0, target = 0;
  for (const GainFit& fit : fits) residual += fit.residual_squares, target += fit.target_squares;
  return target > 0 ? std::sqrt(residual / target) : 0;
}

// Coordinate descent over (along, across) on the grid of kFootprintStepPx.
FootprintFit FitFootprint(const StackPair& pair, const std::string& camera) {
  const std::vector<int>& observations = pair.by_camera.at(camera);
  FootprintFit fit;
  fit.footprint.camera = camera;
  fit.residual_unblurred = fit.residual_blurred = RelativeResidual(FitObservations(pair, observations, fit.footprint));
  for (int round = 0; round < 2; ++round) {
    for (double CameraFootprint::*axis : {&CameraFootprint::along_px, &CameraFootprint::across_px}) {
      for (double px = 0; px <= kLargestTriedPx + 1e-9; px += kFootprintStepPx) {
        CameraFootprint tried = fit.footprint;
        tried.*axis = px;
        const double residual = RelativeResidual(FitObservations(pair, observations, tried));
        if (residual < fit.residual_blurred) fit.residual_blurred = residual, fit.footprint = tried;
      }
    }
  }
  return fit;
}

const CameraFootprint* FindFootprint(const ScanEmulation& emulation, const std::string& camera) {
  for (const CameraFootprint& footprint : emulation.footprints) {
    if (footprint.camera == camera) return &footprint;
  }
  return nullptr;
}

// The gains' spread and the noise law σ² = noise² · L · m, fitted to the residuals left by the
// fitted footprints; the noise bins compare the law with the residuals.
void FitGainsAndNoise(const StackPair& pair, ScanEmulationMatch& match) {
  const int observations = static_cast<int>(pair.fast_planes.size());
  std::vector<double> log_gains;
  match.noise_bins = {{0, 0.25}, {0.25, 0.5}, {0.5, 1}, {1, 2}, {2, 4}, {4, INFINITY}};
  std::vector<double> bin_squares(match.noise_bins.size()), bin_law(match.noise_bins.size());
  double squares = 0, law = 0;
  for (int k = 0; k < observations; ++k) {
    const Kernel kernel =
        FootprintKernel(*FindFootprint(match.emulation, pair.fast.observations[k].camera), pair.fast.observations[k].camera_mm);
    const Plane model = Blur(pair.fast_planes[k], kernel);
    const GainFit fit = FitGain(model, pair.target_planes[k]);
    const double mean = MeanSeen(pair.target_planes[k]);
    if (!(mean > 0) || !(fit.gain > 0)) continue;
    log_gains.push_back(std::log(fit.gain));
    for (size_t i = 0; i < model.values.size(); ++i) {
      const double l = fit.gain * model.values[i], t = pair.target_planes[k].values[i];
      if (!std::isfinite(l) || !std::isfinite(t)) continue;
      const double r = t - l, lm = std::max(l, 0.0) * mean;
      squares += r * r, law += lm;
      for (size_t b = 0; b < match.noise_bins.size(); ++b) {
        NoiseBin& bin = match.noise_bins[b];
        if (l / mean < bin.low || l / mean >= bin.high) continue;
        ++bin.pixels;
        bin_squares[b] += r * r / (mean * mean);
        bin_law[b] += lm / (mean * mean);
      }
    }
  }
  double log_mean = 0, log_squares = 0;
  for (double g : log_gains) log_mean += g / log_gains.size();
  for (double g : log_gains) log_squares += (g - log_mean) * (g - log_mean);
  match.gain_mean = std::exp(log_mean);
  match.emulation.gain_spread = log_gains.size() > 1 ? std::sqrt(log_squares / (log_gains.size() - 1)) : 0;
  match.emulation.noise = law > 0 ? std::sqrt(squares / law) : 0;
  for (size_t b = 0; b < match.noise_bins.size(); ++b) {
    NoiseBin& bin = match.noise_bins[b];
    if (bin.pixels == 0) continue;
    bin.measured = std::sqrt(bin_squares[b] / bin.pixels);
    bin.predicted = match.emulation.noise * std::sqrt(bin_law[b] / bin.pixels);
  }
}

// RMS of a − b over RMS of b, where both are seen.
double RelativeDistance(const Plane& a, const Plane& b) {
  double difference = 0, reference = 0;
  for (size_t i = 0; i < a.values.size(); ++i) {
    if (!std::isfinite(a.values[i]) || !std::isfinite(b.values[i])) continue;
    difference += (a.values[i] - b.values[i]) * (a.values[i] - b.values[i]);
    reference += b.values[i] * b.values[i];
  }
  return reference > 0 ? std::sqrt(difference / reference) : 0;
}

void CheckAgainstReconstruction(const StackPair& pair, ScanEmulationMatch& match) {
  ObservationStack emulated = pair.fast;
  const Status emulated_ok = EmulateScan(match.emulation, 1, emulated);
  LOOM_CHECK(emulated_ok.ok()) << emulated_ok.ToString();  // every camera has its footprint
  std::vector<double> distances, fast_ratios, emulated_ratios;
  for (size_t k = 0; k < pair.fast_planes.size(); ++k) {
    const Plane emulated_plane = ReadPlane(emulated, static_cast<int>(k));
    const double scan_distance = RelativeDistance(pair.target_planes[k], pair.fast_planes[k]);
    const double target_energy = HighFrequencyEnergy(pair.target_planes[k]);
    if (!(scan_distance > 0) || !(target_energy > 0)) continue;
    distances.push_back(RelativeDistance(emulated_plane, pair.fast_planes[k]) / scan_distance);
    fast_ratios.push_back(HighFrequencyEnergy(pair.fast_planes[k]) / target_energy);
    emulated_ratios.push_back(HighFrequencyEnergy(emulated_plane) / target_energy);
  }
  match.distance_emulated = Median(distances);
  match.high_frequency_fast = Median(fast_ratios);
  match.high_frequency_emulated = Median(emulated_ratios);
}

Status CheckSameLayout(const ObservationStack& fast, const ObservationStack& reconstructed) {
  const auto shape = [](const ObservationStack& s) {
    return std::to_string(s.image.width()) + "x" + std::to_string(s.image.height()) + " px, " +
           std::to_string(s.observations.size()) + " observations";
  };
  if (fast.image.width() != reconstructed.image.width() || fast.image.height() != reconstructed.image.height() ||
      fast.observations.size() != reconstructed.observations.size()) {
    return InvalidArgumentError("stacks", "the fast path (" + shape(fast) + ") and the reconstruction (" + shape(reconstructed) +
                                              ") are not of one grid and plan");
  }
  for (size_t k = 0; k < fast.observations.size(); ++k) {
    if (fast.observations[k].camera != reconstructed.observations[k].camera) {
      return InvalidArgumentError("stacks", "observation " + std::to_string(k) + " is from " + fast.observations[k].camera +
                                                " in the fast path but from " + reconstructed.observations[k].camera +
                                                " in the reconstruction");
    }
  }
  if (fast.observations.empty()) return InvalidArgumentError("stacks", "no observations");
  return Status::Ok();
}

}  // namespace

Status ScanEmulation::Check() const {
  std::vector<std::string> problems;
  if (footprints.empty()) problems.push_back("footprints: none (one per camera)");
  for (size_t i = 0; i < footprints.size(); ++i) {
    const CameraFootprint& f = footprints[i];
    const std::string key = "footprints[" + std::to_string(i) + "]";
    if (f.camera.empty()) problems.push_back(key + ".camera is empty");
    if (!(f.along_px >= 0 && f.along_px <= kMaxFootprintPx)) problems.push_back(key + ".along_px must be in [0, 4]");
    if (!(f.across_px >= 0 && f.across_px <= kMaxFootprintPx)) problems.push_back(key + ".across_px must be in [0, 4]");
  }
  if (!(gain_spread >= 0 && gain_spread <= 1)) problems.push_back("gain_spread must be in [0, 1]");
  if (!(noise >= 0 && noise <= 1)) problems.push_back("noise must be in [0, 1]");
  return ProblemsStatus("scan emulation", problems);
}

nlohmann::json ScanEmulation::ToJson() const {
  nlohmann::json cameras = nlohmann::json::array();
  for (const CameraFootprint& f : footprints) {
    cameras.push_back({{"camera", f.camera}, {"along_px", f.along_px}, {"across_px", f.across_px}});
  }
  return {{"footprints", cameras}, {"gain_spread", gain_spread}, {"noise", noise}};
}

std::string ScanEmulation::ToYaml() const {
  std::ostringstream out;
  out << std::setprecision(4);
  out << kLoomTextMarker << "\n";
  out << "schema_version: " << kScanEmulationSchemaVersion << "\n";
  out << "# What a scan's reconstruction adds to the fast path (loom sim match-scan); loom train --scan-emulation\n";
  out << "footprints:\n";
  for (const CameraFootprint& f : footprints) {
    out << "  - {camera: " << f.camera << ", along_px: " << f.along_px << ", across_px: " << f.across_px << "}\n";
  }
  out << "gain_spread: " << gain_spread << "\n";
  out << "noise: " << noise << "\n";
  return out.str();
}

Result<ScanEmulation> LoadScanEmulation(const std::filesystem::path& path) {
  LOOM_ASSIGN_OR_RETURN(ConfigDocument doc, ConfigDocument::LoadFile(path, kScanEmulationSchemaVersion));
  const ConfigNode root = doc.root();
  ScanEmulation emulation;
  for (const ConfigNode& node : root.Sequence("footprints")) {
    CameraFootprint& f = emulation.footprints.emplace_back();
    node.Required("camera", &f.camera);
    node.Required("along_px", &f.along_px);
    node.Required("across_px", &f.across_px);
  }
  root.Required("gain_spread", &emulation.gain_spread);
  root.Required("noise", &emulation.noise);
  LOOM_RETURN_IF_ERROR(doc.Finish());
  if (Status checked = emulation.Check(); !checked.ok()) return InvalidArgumentError(path.string(), checked.message());
  return emulation;
}

Status EmulateScan(const ScanEmulation& emulation, uint64_t seed, ObservationStack& stack) {
  LOOM_RETURN_IF_ERROR(emulation.Check());
  for (const StackObservation& observation : stack.observations) {
    if (!FindFootprint(emulation, observation.camera)) {
      return NotFoundError("scan emulation", "no footprint for camera " + observation.camera);
    }
  }
  ParallelFor(static_cast<int>(stack.observations.size()), 0, [&](int k) {
    const StackObservation& observation = stack.observations[k];
    internal::Rng rng(internal::Mix(seed) ^ (static_cast<uint64_t>(k) * 0x9E3779B97F4A7C15ull));
    Plane plane =
        Blur(ReadPlane(stack, k), FootprintKernel(*FindFootprint(emulation, observation.camera), observation.camera_mm));
    const double gain = std::exp(emulation.gain_spread * rng.Normal());
    const double mean = MeanSeen(plane) * gain;
    for (double& v : plane.values) {
      if (!std::isfinite(v)) continue;
      v *= gain;
      v += emulation.noise * std::sqrt(std::max(v, 0.0) * mean) * rng.Normal();
    }
    WritePlane(plane, k, stack);
  });
  return Status::Ok();
}

Result<ScanEmulationMatch> MatchScanEmulation(const ObservationStack& fast, const ObservationStack& reconstructed) {
  LOOM_RETURN_IF_ERROR(CheckSameLayout(fast, reconstructed));
  StackPair pair{fast, {}, {}, {}};
  for (int k = 0; k < static_cast<int>(fast.observations.size()); ++k) {
    pair.fast_planes.push_back(ReadPlane(fast, k));
    pair.target_planes.push_back(ReadPlane(reconstructed, k));
    pair.by_camera[fast.observations[k].camera].push_back(k);
  }
  ScanEmulationMatch match;
  for (const auto& [camera, observations] : pair.by_camera) {
    match.cameras.push_back(FitFootprint(pair, camera));
    match.emulation.footprints.push_back(match.cameras.back().footprint);
  }
  FitGainsAndNoise(pair, match);
  CheckAgainstReconstruction(pair, match);
  return match;
}

nlohmann::json ScanEmulationMatch::ToJson() const {
  nlohmann::json fits = nlohmann::json::array(), bins = nlohmann::json::array();
  for (const FootprintFit& fit : cameras) {
    fits.push_back({{"camera", fit.footprint.camera},
                    {"residual_unblurred", fit.residual_unblurred},
                    {"residual_blurred", fit.residual_blurred}});
  }
  for (const NoiseBin& bin : noise_bins) {
    bins.push_back({{"low", bin.low},
                    {"high", std::isfinite(bin.high) ? nlohmann::json(bin.high) : nlohmann::json(nullptr)},
                    {"pixels", bin.pixels},
                    {"measured", bin.measured},
                    {"predicted", bin.predicted}});
  }
  return {{"emulation", emulation.ToJson()},
          {"gain_mean", gain_mean},
          {"cameras", fits},
          {"noise_bins", bins},
          {"distance_emulated_over_scan", distance_emulated},
          {"high_frequency_fast_over_scan", high_frequency_fast},
          {"high_frequency_emulated_over_scan", high_frequency_emulated}};
}

void ScanEmulationMatch::Report(std::ostream& out) const {
  out << std::fixed << std::setprecision(3);
  out << "camera footprints (Gaussian σ, stack px) and the reconstruction's residual against the fast path "
         "(RMS over RMS radiance, each observation at its best gain):\n";
  for (const FootprintFit& fit : cameras) {
    out << "  " << fit.footprint.camera << ": along " << fit.footprint.along_px << ", across " << fit.footprint.across_px
        << "; residual " << fit.residual_unblurred << " unblurred, " << fit.residual_blurred << " blurred\n";
  }
  out << "gains: geometric mean " << gain_mean << " (left out of the emulation), log spread " << emulation.gain_spread
      << "; noise: " << emulation.noise << " at the mean radiance\n";
  out << "residual RMS / mean radiance, by radiance / mean: measured (the noise law's)\n";
  for (const NoiseBin& bin : noise_bins) {
    out << "  [" << bin.low << ", " << bin.high << "): " << bin.measured << " (" << bin.predicted << "), " << bin.pixels
        << " pixels\n";
  }
  out << "check, medians over observations: the emulation's distance from the fast path over the scan's " << distance_emulated
      << "; high-frequency energy over the scan's: fast path " << high_frequency_fast << ", emulated " << high_frequency_emulated
      << "\n";
}

}  // namespace loom::sim
