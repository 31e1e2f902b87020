#include "photos/simulated_capture.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <span>
#include <sstream>
#include <vector>

#include <Eigen/Geometry>

#include "core/geometry.h"
#include "photos/capture_export.h"

namespace loom::photos {
namespace {

namespace fs = std::filesystem;

// The truth's albedos in the units of images stored with `white` as the top value.
void InStoredUnits(Image& truth, double white) {
  for (int y = 0; y < truth.height(); ++y) {
    for (int x = 0; x < truth.width(); ++x) {
      for (int c = 3; c < 9; ++c) truth.at(c, y, x) = static_cast<float>(truth.at(c, y, x) / white);  // a_d, a_s
    }
  }
}

// The value below which all but the brightest half percent of the images' values lie.
double ClippingWhite(const std::vector<Image>& images) {
  std::vector<float> values;
  for (const Image& image : images) {
    for (int c = 0; c < 3; ++c) values.insert(values.end(), image.channel(c).begin(), image.channel(c).end());
  }
  const auto top = values.begin() + static_cast<std::ptrdiff_t>(0.995 * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), top, values.end());
  return *top;
}

Result<SimulatedCapture> WriteFlashCapture(const SimulatedCaptureRequest& request, const fs::path& dir) {
  LOOM_RETURN_IF_ERROR(request.flash.Check());
  LOOM_ASSIGN_OR_RETURN(sim::Material material, sim::MakeSample(request.sample));
  const sim::FlashCapture rendered = sim::RenderFlashCapture(material.maps, material.pixel_mm, request.flash);
  const double white = ClippingWhite(rendered.images);
  LOOM_RETURN_IF_ERROR(WriteFlash(dir, {rendered.images, rendered.cameras_cm, rendered.cameras_cm, rendered.width_cm,
                                        Eigen::Vector3d::Constant(request.flash.power), white}));
  InStoredUnits(material.maps, white);
  std::ostringstream description;
  const Eigen::Vector3d& offset = request.flash.flash_offset_cm;
  description << material.name << " under a flash " << offset.x() << "," << offset.y() << "," << offset.z()
              << " cm beside the lens in " << rendered.images.size()
              << " images (flash layout; the files put the flash at the lens)";
  return SimulatedCapture{std::move(material.maps), std::nullopt, white, static_cast<int>(rendered.images.size()),
                          description.str()};
}

// The files' lights as a calibration errs (SimulatedCaptureRequest::light_error_deg and
// intensity_error), the images staying those of the true lights but for each light's intensity.
void MiscalibrateLights(const SimulatedCaptureRequest& request, sim::ObjectCapture& rendered) {
  if (request.light_error_deg == 0 && request.intensity_error == 0) return;
  std::mt19937_64 random(request.object.seed ^ 0x6c696768u);
  std::normal_distribution<double> normal(0, 1);
  for (size_t k = 0; k < rendered.light_directions.size(); ++k) {
    Eigen::Vector3d& l = rendered.light_directions[k];
    const Eigen::Vector3d axis = l.cross(Eigen::Vector3d(normal(random), normal(random), normal(random))).normalized();
    const double turn = DegToRad(std::abs(normal(random)) * request.light_error_deg);
    l = Eigen::AngleAxisd(turn, axis) * l;
    const double intensity = std::max(0.5, 1 + request.intensity_error * normal(random));
    for (float& v : std::span<float>(rendered.images[k].data(), rendered.images[k].pixel_count() * 3)) {
      v = static_cast<float>(v * intensity);
    }
  }
}

Result<SimulatedCapture> WriteObjectCapture(const SimulatedCaptureRequest& request, const fs::path& dir) {
  LOOM_RETURN_IF_ERROR(request.object.Check());
  sim::ObjectCapture rendered = sim::RenderObjectCapture(request.object);
  MiscalibrateLights(request, rendered);
  double brightest = 0;
  for (const Image& image : rendered.images) {
    for (int c = 0; c < 3; ++c) {
      for (float v : image.channel(c)) brightest = std::max(brightest, static_cast<double>(v));
    }
  }
  const double white = std::max(1.0, 1.01 * brightest);
  InStoredUnits(rendered.truth, white);
  const int images = static_cast<int>(rendered.images.size());
  const PhotometricStereoCapture capture{std::move(rendered.images), rendered.light_directions, rendered.mask, white};
  const bool dome = request.layout == Layout::kLightPositions;
  LOOM_RETURN_IF_ERROR(dome ? WriteLightPositions(dir, capture) : WritePhotometricStereo(dir, capture));
  std::ostringstream description;
  description << "a " << (request.object.shape == sim::ObjectShape::kSphere ? "sphere" : "cylinder") << " under " << images
              << " directional lights, " << request.object.size_px << "x" << request.object.size_px << " px ("
              << (dome ? "lp" : "ps") << " layout; radiance ×" << 1 / white << " as stored";
  if (request.light_error_deg > 0 || request.intensity_error > 0) {
    description << "; the files' lights off the true ones by |N(0, " << request.light_error_deg << "°)| and ×N(1, "
                << request.intensity_error << ")";
  }
  description << ")";
  return SimulatedCapture{std::move(rendered.truth), std::move(rendered.normals), white, images, description.str()};
}

}  // namespace

Status SimulatedCaptureRequest::Check() const {
  std::vector<std::string> problems;
  if (!(light_error_deg >= 0 && light_error_deg <= 20)) problems.push_back("light_error_deg must be in [0, 20]");
  if (!(intensity_error >= 0 && intensity_error <= 0.5)) problems.push_back("intensity_error must be in [0, 0.5]");
  if (layout == Layout::kFlash && (light_error_deg > 0 || intensity_error > 0)) {
    problems.push_back("light_error_deg and intensity_error are the ps and lp layouts' (directional lights)");
  }
  return ProblemsStatus("SimulatedCaptureRequest", problems);
}

Result<SimulatedCapture> WriteSimulatedCapture(const SimulatedCaptureRequest& request, const fs::path& dir) {
  LOOM_RETURN_IF_ERROR(request.Check());
  return request.layout == Layout::kFlash ? WriteFlashCapture(request, dir) : WriteObjectCapture(request, dir);
}

}  // namespace loom::photos
