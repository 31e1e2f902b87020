#include "reconstruction/reconstruct.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <iomanip>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>

#include <Eigen/SVD>
#include <opencv2/imgproc.hpp>

#include "calibration/projector_columns.h"
#include "calibration/scan_radiance.h"
#include "calibration/structured_light.h"
#include "core/heightfield.h"
#include "core/heightmap.h"
#include "core/log.h"
#include "core/memory.h"
#include "core/parallel.h"
#include "core/rig_observation.h"

namespace loom::reconstruction {

using calibration::LightingOf;
using calibration::RadianceView;
using calibration::ScanRadiance;

namespace {

using scan::Step;
using scan::StepKind;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

const CameraModel* TopCamera(const RigModel& rig) {
  const CameraModel* best = nullptr;
  double best_down = -2;
  for (const CameraModel& camera : rig.cameras) {
    // The optical axis (camera z) in the rig frame; straight down is −z.
    const double down = -(camera.cam_from_rig.linear().transpose() * Eigen::Vector3d::UnitZ()).z();
    if (down > best_down) {
      best_down = down;
      best = &camera;
    }
  }
  return best;
}

struct ViewRef {
  int step = 0;
  std::string camera;
};

std::vector<ViewRef> FittingViews(const scan::Plan& plan) {
  std::vector<ViewRef> views;
  for (const Step& step : plan.steps) {
    if (!scan::IsObservationStep(step.kind)) continue;
    for (const std::string& camera : step.cameras) views.push_back({step.index, camera});
  }
  return views;
}

Result<std::vector<float>> Heights(const ScanRadiance& scan, const CameraModel& camera, const ReconstructOptions& options,
                                   int* filled) {
  const RigModel& rig = scan.rig();
  const std::vector<double> angles = calibration::StructuredLightAngles(scan.plan(), scan::ScanObject::kSample);
  const size_t pixels = static_cast<size_t>(options.width_px) * options.height_px;
  if (angles.empty()) {
    LOOM_LOG(Warning) << "the scan has no structured-light steps: the sample is taken as flat (height 0)";
    return std::vector<float>(pixels, 0.0f);
  }
  if (angles.size() > 1) return InvalidArgumentError("structured-light steps", "turntable angles differ within the sequence");
  LOOM_ASSIGN_OR_RETURN(const Image columns,
                        calibration::DecodeScanColumns(scan, camera, scan::ScanObject::kSample, angles.front()));
  const calibration::HeightmapGrid grid{options.width_px, options.height_px, options.pixel_mm, options.min_height_mm,
                                        options.max_height_mm};
  LOOM_ASSIGN_OR_RETURN(calibration::TriangulatedHeights heights,
                        calibration::TriangulateHeights(columns, camera, *rig.projector, rig.turntable, angles.front(), grid));
  *filled = heights.filled;
  return std::move(heights.heights_mm);
}

// The stack (its geometry and one float per observation per pixel) and the heightmap's working
// arrays (heights, their doubles, normals and decoded columns).
uint64_t ReconstructionBytes(const ReconstructOptions& options, size_t observations) {
  const uint64_t pixels = static_cast<uint64_t>(options.width_px) * static_cast<uint64_t>(options.height_px);
  return pixels * ((kStackGeometryChannels + observations) * sizeof(float) + 48);
}

}  // namespace

std::vector<CameraSampling> StackSampling(const RigModel& rig, double pixel_mm) {
  std::vector<CameraSampling> sampling;
  const Rigid3d rig_from_sample = rig.turntable.RigFromSample(0);
  for (const CameraModel& camera : rig.cameras) {
    // The projection's 2 × 2 Jacobian on the sample plane, by central differences of a stack
    // pixel; its smaller singular value is the coarsest direction's pixels per stack pixel.
    Eigen::Matrix2d jacobian;
    bool seen = true;
    for (int axis = 0; axis < 2; ++axis) {
      Eigen::Vector3d step = Eigen::Vector3d::Zero();
      step[axis] = pixel_mm / 2;
      Eigen::Vector2d plus, minus;
      seen = seen && camera.Project(camera.cam_from_rig * (rig_from_sample * step), &plus) &&
             camera.Project(camera.cam_from_rig * (rig_from_sample * Eigen::Vector3d(-step)), &minus);
      jacobian.col(axis) = plus - minus;
    }
    const double coarsest = seen ? Eigen::JacobiSVD<Eigen::Matrix2d>(jacobian).singularValues()[1] : 0.0;
    sampling.push_back({camera.name, coarsest});
  }
  return sampling;
}

Status ReconstructOptions::Check() const {
  std::vector<std::string> problems;
  if (width_px < 1 || height_px < 1 || width_px > kMaxStackSide || height_px > kMaxStackSide) {
    problems.push_back("width_px and height_px must be in [1, " + std::to_string(kMaxStackSide) + "]");
  }
  // Below a micrometre no rig resolves anything, and the heightmap's blur in pixels explodes.
  if (!(pixel_mm >= 1e-3 && pixel_mm <= 100)) problems.push_back("pixel_mm must be in [0.001, 100]");
  if (!(normal_blur_mm >= 0 && normal_blur_mm <= 100)) problems.push_back("normal_blur_mm must be in [0, 100]");
  if (!(std::isfinite(min_height_mm) && std::isfinite(max_height_mm) && min_height_mm < max_height_mm)) {
    problems.push_back("min_height_mm must be below max_height_mm, both finite");
  }
  if (threads < 0) problems.push_back("threads must be ≥ 0");
  if (!(light_drift_warn_percent > 0 && std::isfinite(light_drift_warn_percent))) {
    problems.push_back("light_drift_warn_percent must be > 0 and finite");
  }
  return ProblemsStatus("ReconstructOptions", problems);
}

std::vector<float> SampleCamera(const Image& image, const std::vector<Eigen::Vector2f>& pixels, double camera_px_per_stack_px) {
  if (pixels.empty()) return {};
  // remap's maps, rows of at most kRow coordinates (remap takes fewer than 2^15 rows and
  // columns; kMaxStackSide² fits); NaN and the padding become a coordinate off the image.
  constexpr size_t kRow = 16384;
  constexpr float kOffImage = -10;
  const int cols = static_cast<int>(std::min(pixels.size(), kRow));
  const int rows = static_cast<int>((pixels.size() + kRow - 1) / kRow);
  cv::Mat map_x(rows, cols, CV_32F, cv::Scalar(kOffImage)), map_y(rows, cols, CV_32F, cv::Scalar(kOffImage));
  for (size_t i = 0; i < pixels.size(); ++i) {
    if (!pixels[i].allFinite()) continue;
    map_x.at<float>(static_cast<int>(i / kRow), static_cast<int>(i % kRow)) = pixels[i].x();
    map_y.at<float>(static_cast<int>(i / kRow), static_cast<int>(i % kRow)) = pixels[i].y();
  }
  // Read only: remap's source.
  const cv::Mat source(image.height(), image.width(), CV_32F, const_cast<float*>(image.channel(0).data()));
  cv::Mat sampled;
  const int interpolation = camera_px_per_stack_px >= kFineSampling ? cv::INTER_LINEAR : cv::INTER_CUBIC;
  cv::remap(source, sampled, map_x, map_y, interpolation, cv::BORDER_CONSTANT, cv::Scalar(kNaN));
  std::vector<float> values(sampled.begin<float>(), sampled.end<float>());
  values.resize(pixels.size());
  return values;
}

Result<Reconstruction> Reconstruct(const scan::CaptureStore& store, const RigModel& rig, const ReconstructOptions& options,
                                   const std::function<void(const ReconstructProgress&)>& progress) {
  LOOM_RETURN_IF_ERROR(options.Check());
  if (store.info().plan.purpose != scan::PlanPurpose::kMaterial) {
    return InvalidArgumentError(
        store.directory().string(),
        "is a " + std::string(scan::PlanPurposeName(store.info().plan.purpose)) + " scan; reconstruction takes material scans");
  }
  LOOM_ASSIGN_OR_RETURN(const ScanRadiance scan, ScanRadiance::Open(store, rig));
  const CameraModel* camera = options.heightmap_camera.empty() ? TopCamera(rig) : rig.FindCamera(options.heightmap_camera);
  if (camera == nullptr) return NotFoundError("camera '" + options.heightmap_camera + "'", "not in rig '" + rig.name + "'");
  const std::vector<ViewRef> views = FittingViews(scan.plan());
  LOOM_RETURN_IF_ERROR(
      CheckFitsInMemory(ReconstructionBytes(options, views.size()), "a stack of " + std::to_string(options.width_px) + " × " +
                                                                        std::to_string(options.height_px) + " px with " +
                                                                        std::to_string(views.size()) + " observations"));
  Reconstruction result;
  result.sampling = StackSampling(rig, options.pixel_mm);
  result.heightmap_camera = camera->name;
  if (progress) progress({"heightmap", 0, 1});
  LOOM_ASSIGN_OR_RETURN(const std::vector<float> heights, Heights(scan, *camera, options, &result.heightmap_filled));
  if (progress) progress({"heightmap", 1, 1});

  const int w = options.width_px;
  const int h = options.height_px;
  const std::vector<double> heights_d(heights.begin(), heights.end());
  const std::vector<Eigen::Vector3d> normals = GeometricNormals(heights_d, w, h, options.pixel_mm, options.normal_blur_mm);
  const Heightmap heightmap(heights, w, h, options.pixel_mm);

  LOOM_ASSIGN_OR_RETURN(const scan::LightDrift drift, scan.LightDrift());
  result.light_drift = drift.leds.references();
  result.linear_light_drift = drift.strip.references();
  result.light_drift_corrected = options.correct_light_drift && !drift.leds.references().empty();
  for (const scan::LightDriftTrack* track : {&drift.leds, &drift.strip}) {
    if (track->MaxDriftPercent() <= options.light_drift_warn_percent) continue;
    LOOM_LOG(Warning) << (track == &drift.strip ? "the linear light" : "the LEDs") << " drifted up to "
                      << track->MaxDriftPercent() << " % through the scan (threshold " << options.light_drift_warn_percent
                      << " %)"
                      << (result.light_drift_corrected ? ": the observations they lit are corrected" : ", not corrected");
  }
  std::vector<StackObservation> table(views.size());
  result.stack = MakeObservationStack(w, h, options.pixel_mm, std::vector<StackObservation>(views.size()));
  result.stack.rig = rig.name;
  result.stack.source = "reconstruction of " + store.directory().string();
  Image& stack = result.stack.image;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      stack.at(0, y, x) = static_cast<float>((x + 0.5 - w / 2.0) * options.pixel_mm);
      stack.at(1, y, x) = static_cast<float>((y + 0.5 - h / 2.0) * options.pixel_mm);
      stack.at(2, y, x) = heights[y * w + x];
      for (int i = 0; i < 3; ++i) stack.at(3 + i, y, x) = static_cast<float>(normals[y * w + x][i]);
    }
  }
  std::mutex mutex;
  Status failure;
  std::atomic<int> saturated = 0;
  std::atomic<long long> unseen = 0;
  ParallelFor(
      static_cast<int>(views.size()), ThreadCount(options.threads),
      [&](int k) {
        const std::string where = "scan " + store.directory().string() + ", step " + std::to_string(views[k].step) +
                                  ", camera '" + views[k].camera + "'";
        Result<RadianceView> view = scan.View(views[k].step, views[k].camera);
        Result<LightingState> lighting = view.ok() ? LightingOf(rig, view->state, where) : Result<LightingState>(view.status());
        Result<StackObservation> described =
            lighting.ok() ? DescribeRigObservation(rig, view->camera, *lighting) : Result<StackObservation>(lighting.status());
        if (!described.ok()) {
          std::lock_guard lock(mutex);
          if (failure.ok()) failure = described.status();
          return;
        }
        table[k] = *std::move(described);
        saturated += view->saturated_pixels;
        const float drift_scale = result.light_drift_corrected
                                      ? static_cast<float>(1 / drift.Of(scan.plan().steps[views[k].step]).FactorAt(views[k].step))
                                      : 1.0f;
        const CameraModel& cam = rig.cameras[view->camera];
        const Rigid3d cam_from_sample = cam.cam_from_rig * rig.turntable.RigFromSample(table[k].turntable_deg);
        const int channel = ObservationStack::ObservationChannel(k);
        // Where each stack pixel lies in the camera image; NaN where the relief hides it.
        std::vector<Eigen::Vector2f> pixels(static_cast<size_t>(w) * h, Eigen::Vector2f::Constant(kNaN));
        for (int y = 0; y < h; ++y) {
          for (int x = 0; x < w; ++x) {
            const Eigen::Vector3d p = result.stack.Position(x, y);
            Eigen::Vector2d pixel;
            if (heightmap.Shadowed(p, table[k].camera_mm) || !cam.Project(cam_from_sample * p, &pixel)) continue;
            pixels[static_cast<size_t>(y) * w + x] = pixel.cast<float>();
          }
        }
        const std::vector<float> sampled =
            SampleCamera(view->radiance, pixels, result.sampling[view->camera].camera_px_per_stack_px);
        long long hidden = 0;
        for (int y = 0; y < h; ++y) {
          for (int x = 0; x < w; ++x) {
            const float value = sampled[static_cast<size_t>(y) * w + x];
            if (std::isnan(value)) ++hidden;
            stack.at(channel, y, x) = value * drift_scale;
          }
        }
        unseen += hidden;
      },
      [&](int done) {
        if (progress) progress({"observations", done, static_cast<int>(views.size())});
      });
  LOOM_RETURN_IF_ERROR(failure);
  result.stack.observations = std::move(table);
  result.saturated_pixels = saturated;
  result.unseen_fraction = views.empty() ? 0.0 : static_cast<double>(unseen) / (static_cast<double>(views.size()) * w * h);
  return result;
}

nlohmann::json Reconstruction::ToJson() const {
  nlohmann::json per_camera = nlohmann::json::object();
  for (const CameraSampling& s : sampling) per_camera[s.camera] = s.camera_px_per_stack_px;
  return {{"width_px", stack.image.width()},
          {"height_px", stack.image.height()},
          {"pixel_mm", stack.pixel_mm},
          {"observations", stack.observations.size()},
          {"camera_px_per_stack_px", per_camera},
          {"heightmap_camera", heightmap_camera},
          {"heightmap_filled_pixels", heightmap_filled},
          {"saturated_pixels", saturated_pixels},
          {"unseen_fraction", unseen_fraction},
          {"light_drift", LightDriftJson()}};
}

nlohmann::json Reconstruction::LightDriftJson() const {
  nlohmann::json references = nlohmann::json::array();
  for (const auto& [step, output] : light_drift) references.push_back({{"step", step}, {"output", output}});
  nlohmann::json strip_references = nlohmann::json::array();
  for (const auto& [step, output] : linear_light_drift) strip_references.push_back({{"step", step}, {"output", output}});
  return {{"references", references},
          {"max_percent", scan::LightDriftTrack::MaxDriftPercentOf(light_drift)},
          {"linear_light_references", strip_references},
          {"linear_light_max_percent", scan::LightDriftTrack::MaxDriftPercentOf(linear_light_drift)},
          {"corrected", light_drift_corrected}};
}

std::string Reconstruction::CoarseSamplingNote() const {
  const bool coarse = std::any_of(sampling.begin(), sampling.end(),
                                  [](const CameraSampling& s) { return s.camera_px_per_stack_px < kFineSampling; });
  if (!coarse) return "";
  std::ostringstream note;
  note << "the stack's " << stack.pixel_mm << " mm pixels span";
  for (size_t i = 0; i < sampling.size(); ++i) {
    note << (i == 0 ? " " : ", ") << std::fixed << std::setprecision(2) << sampling[i].camera_px_per_stack_px << " ("
         << sampling[i].camera << ")";
  }
  note << std::defaultfloat << " camera pixels at the coarsest; below " << kFineSampling
       << " the observations are blurred over neighbouring stack pixels: a larger --pixel-mm or finer cameras "
          "sharpen them (reconstruction/README.md)";
  return note.str();
}

}  // namespace loom::reconstruction
