#include "calibration/radiometry.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <numbers>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "core/parallel.h"
#include "core/spectra.h"

namespace loom::calibration {
namespace {

using scan::StepKind;

// Every sensor pixel's ray in its camera's frame (CameraModel::Unproject), for each camera of the
// rig, worked out once on every core: unprojected again for each view and pixel, they had been a
// seventh of calibrating tac7's radiometry (perf).
class SensorRays {
 public:
  explicit SensorRays(const RigModel& rig) : rig_(rig), rays_(rig.cameras.size()) {
    for (size_t c = 0; c < rig.cameras.size(); ++c) {
      const CameraModel& camera = rig.cameras[c];
      std::vector<Eigen::Vector3d>& rays = rays_[c];
      rays.resize(static_cast<size_t>(camera.width) * camera.height);
      ParallelFor(camera.height, 0, [&](int y) {
        for (int x = 0; x < camera.width; ++x)
          rays[static_cast<size_t>(y) * camera.width + x] = camera.Unproject(Eigen::Vector2d(x, y));
      });
    }
  }

  const RigModel& rig() const { return rig_; }
  const Eigen::Vector3d& At(int camera, int x, int y) const {
    return rays_[camera][static_cast<size_t>(y) * rig_.cameras[camera].width + x];
  }

 private:
  const RigModel& rig_;
  std::vector<std::vector<Eigen::Vector3d>> rays_;  // by camera, row-major
};

// Where a camera's pixels look on the turntable's plane (z = 0 in the sample frame at a view's
// angle), for those that look down at it. The camera's pose is worked out once: per pixel it had
// been a tenth of calibrating tac7's radiometry (perf).
class TurntablePoints {
 public:
  TurntablePoints(const SensorRays& rays, int camera, double turntable_deg)
      : rays_(rays),
        camera_(camera),
        sample_from_cam_(rays.rig().turntable.RigFromSample(turntable_deg).inverse() *
                         rays.rig().cameras[camera].cam_from_rig.inverse()) {}

  std::optional<Eigen::Vector3d> At(int x, int y) const {
    const Eigen::Vector3d origin = sample_from_cam_.translation();
    const Eigen::Vector3d direction = sample_from_cam_.linear() * rays_.At(camera_, x, y);
    if (direction.z() >= 0) return std::nullopt;
    return origin + direction * (-origin.z() / direction.z());
  }

 private:
  const SensorRays& rays_;
  const int camera_;
  const Rigid3d sample_from_cam_;
};

// The irradiance one emitter gives a flat surface (normal +z) at `p`.
double Irradiance(const PointEmitter& emitter, const Eigen::Vector3d& p) {
  const Eigen::Vector3d to_light = emitter.position_mm - p;
  const double d2 = to_light.squaredNorm();
  const double cos_incidence = to_light.z() / std::sqrt(d2);
  return cos_incidence > 0 ? emitter.IntensityTowards(p) * cos_incidence / d2 : 0;
}

// Radiance of a flat grey Lambertian surface of albedo 1 at `p` under the view's emitters.
double UnitAlbedoRadiance(const StackObservation& observation, const Eigen::Vector3d& p) {
  double irradiance = 0;
  for (const PointEmitter& emitter : observation.emitters) irradiance += Irradiance(emitter, p);
  return irradiance / std::numbers::pi;
}

double Median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto middle = values.begin() + values.size() / 2;
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

double Percentile(std::vector<double> values, double fraction) {
  const auto at = values.begin() + static_cast<long>(fraction * (values.size() - 1));
  std::nth_element(values.begin(), at, values.end());
  return *at;
}

// (r / r_corner)² at a pixel: the vignetting model's variable.
double CornerRadius2(const CameraModel& camera, int x, int y) {
  SensorModel unit = camera.sensor;
  unit.vignetting = 1;
  return 1 - unit.QuadraticResponse(x, y, camera.width, camera.height);
}

// The light of a white-reference view: an LED index, or −1 for the linear light.
Result<int> LightOf(const LitView& view) {
  const LightingState& lighting = view.lighting;
  if (lighting.leds.size() == 1 && !lighting.linear_light_on) return lighting.leds.front().first;
  if (lighting.leds.empty() && lighting.linear_light_on) return -1;
  return InvalidArgumentError(view.source, "a white-reference view must be lit by one LED or the linear light alone");
}

std::string LightName(int led) { return led < 0 ? "linear light" : "led " + std::to_string(led); }

// One white-reference view on the tile: pixels well inside it, with the recorded radiance over
// the rig model's prediction.
struct TileView {
  int camera = 0;
  int led = 0;              // −1: the linear light
  std::vector<int> pixels;  // y · width + x
  std::vector<double> ratio;
  double median = 0;
};

Result<TileView> OnTile(const SensorRays& rays, const LitView& view, double albedo, int edge_px) {
  const RigModel& rig = rays.rig();
  const CameraModel& camera = rig.cameras.at(view.camera);
  LOOM_ASSIGN_OR_RETURN(const int led, LightOf(view));
  LOOM_ASSIGN_OR_RETURN(const StackObservation observation, DescribeRigObservation(rig, view.camera, view.lighting));
  const double weight = observation.rgb_weights.sum();
  const TurntablePoints points(rays, view.camera, view.lighting.turntable_deg);
  cv::Mat ratio(camera.height, camera.width, CV_64F, cv::Scalar(std::numeric_limits<double>::quiet_NaN()));  // NaN: none
  // Row by row on every core: a whole frame's pixels, each unprojected and lit by the model.
  ParallelFor(camera.height, 0, [&](int y) {
    for (int x = 0; x < camera.width; ++x) {
      const double measured = view.radiance.at(0, y, x);
      const std::optional<Eigen::Vector3d> p = points.At(x, y);
      if (!p || !std::isfinite(measured)) continue;
      const double predicted = albedo * weight * UnitAlbedoRadiance(observation, *p);
      if (predicted > 0) ratio.at<double>(y, x) = measured / predicted;
    }
  });
  std::vector<double> valid;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      if (!std::isnan(ratio.at<double>(y, x))) valid.push_back(ratio.at<double>(y, x));
    }
  }
  if (valid.empty()) return FailedPreconditionError(view.source, "no pixel looks at the turntable");
  // The tile is what reads near the prediction; the holder around it is dark. Its edge mixes both.
  cv::Mat on_tile = ratio > 0.4 * Percentile(valid, 0.9);
  cv::erode(on_tile, on_tile, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * edge_px + 1, 2 * edge_px + 1)));
  TileView tile{view.camera, led, {}, {}, 0};
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      if (on_tile.at<uint8_t>(y, x) == 0) continue;
      tile.pixels.push_back(y * camera.width + x);
      tile.ratio.push_back(ratio.at<double>(y, x));
    }
  }
  tile.median = Median(tile.ratio);
  return tile;
}

struct FlatField {
  double vignetting = 0;
  double residual = 0;
  std::shared_ptr<const Image> per_pixel;  // over the quadratic model
  double per_pixel_max = 0;
};

// The per-pixel map: the tile's response over the fitted quadratic model (`over_model`, one per
// sensor pixel, NaN off the tile), smoothed by a Gaussian of `smoothing_px` over the tile's pixels
// alone (normalised convolution), feathered to 1 over about two widths beyond the tile, where
// nothing measured it.
std::shared_ptr<const Image> PerPixelFlat(const CameraModel& camera, const std::vector<double>& over_model, double smoothing_px,
                                          double* largest_departure) {
  cv::Mat value(camera.height, camera.width, CV_64F, cv::Scalar(0)), seen(camera.height, camera.width, CV_64F, cv::Scalar(0));
  for (size_t pixel = 0; pixel < over_model.size(); ++pixel) {
    if (std::isnan(over_model[pixel])) continue;
    value.at<double>(static_cast<int>(pixel)) = over_model[pixel] - 1;
    seen.at<double>(static_cast<int>(pixel)) = 1;
  }
  if (smoothing_px > 0) {
    cv::GaussianBlur(value, value, cv::Size(), smoothing_px, smoothing_px, cv::BORDER_CONSTANT);
    cv::GaussianBlur(seen, seen, cv::Size(), smoothing_px, smoothing_px, cv::BORDER_CONSTANT);
  }
  auto flat = std::make_shared<Image>(camera.width, camera.height, std::vector<std::string>{"flat"});
  *largest_departure = 0;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const double weight = seen.at<double>(y, x);
      const double departure = weight > 1e-3 ? value.at<double>(y, x) / weight * std::min(1.0, 2 * weight) : 0;
      flat->at(0, y, x) = static_cast<float>(1 + departure);
      if (!std::isnan(over_model[static_cast<size_t>(y) * camera.width + x])) {
        *largest_departure = std::max(*largest_departure, std::abs(departure));
      }
    }
  }
  return flat;
}

// The vignetting model through the camera's ratio images: S · R_rig = k (1 − v q), linear in
// (k, k·v); then, per pixel on the tile, what that model leaves. Per sensor pixel in dense
// arrays, in pixel order (a map by pixel had been a fifth of calibrating tac7's radiometry).
Result<FlatField> FitFlatField(const CameraModel& camera, const std::vector<const TileView*>& views, double smoothing_px) {
  const size_t sensor_pixels = static_cast<size_t>(camera.width) * camera.height;
  std::vector<double> shape_sum(sensor_pixels, 0);  // Σ ratio / median
  std::vector<int> shape_views(sensor_pixels, 0);
  for (const TileView* view : views) {
    for (size_t i = 0; i < view->pixels.size(); ++i) {
      shape_sum[view->pixels[i]] += view->ratio[i] / view->median;
      ++shape_views[view->pixels[i]];
    }
  }
  const long seen = std::count_if(shape_views.begin(), shape_views.end(), [](int n) { return n > 0; });
  if (seen < 100) {
    return FailedPreconditionError("camera '" + camera.name + "'", "sees the white reference in " + std::to_string(seen) +
                                                                       " pixels: too few for its flat field (at least 100)");
  }
  Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
  Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
  const double kNone = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> q_of(sensor_pixels, kNone), value_of(sensor_pixels, kNone);  // q, the response up to a scale
  for (size_t pixel = 0; pixel < sensor_pixels; ++pixel) {
    if (shape_views[pixel] == 0) continue;
    const int x = static_cast<int>(pixel % camera.width), y = static_cast<int>(pixel / camera.width);
    const double q = CornerRadius2(camera, x, y);
    const double value =
        shape_sum[pixel] / shape_views[pixel] * camera.sensor.RelativeResponse(x, y, camera.width, camera.height);
    const Eigen::Vector2d row(1, -q);
    normal += row * row.transpose();
    rhs += row * value;
    q_of[pixel] = q;
    value_of[pixel] = value;
  }
  const Eigen::Vector2d solution = normal.ldlt().solve(rhs);  // (k, k·v)
  FlatField flat{solution[1] / solution[0], 0, nullptr, 0};
  double sum2 = 0;
  std::vector<double> over_model(sensor_pixels, kNone);
  for (size_t pixel = 0; pixel < sensor_pixels; ++pixel) {
    if (shape_views[pixel] == 0) continue;
    const double model = solution[0] * (1 - flat.vignetting * q_of[pixel]);
    sum2 += (value_of[pixel] - model) * (value_of[pixel] - model) / (model * model);
    over_model[pixel] = value_of[pixel] / model;
  }
  flat.residual = std::sqrt(sum2 / static_cast<double>(seen));
  flat.per_pixel = PerPixelFlat(camera, over_model, smoothing_px, &flat.per_pixel_max);
  return flat;
}

// The view's scale once the camera's flat field is taken out.
double ScaleOf(const CameraModel& camera, const TileView& view, const FlatField& flat) {
  SensorModel calibrated = camera.sensor;
  calibrated.vignetting = flat.vignetting;
  calibrated.flat_field = flat.per_pixel;
  std::vector<double> scaled;
  for (size_t i = 0; i < view.pixels.size(); ++i) {
    const int x = view.pixels[i] % camera.width, y = view.pixels[i] / camera.width;
    scaled.push_back(view.ratio[i] * camera.sensor.RelativeResponse(x, y, camera.width, camera.height) /
                     calibrated.RelativeResponse(x, y, camera.width, camera.height));
  }
  return Median(scaled);
}

int ReferenceCamera(const RigModel& rig, const std::string& name) {
  if (!name.empty()) {
    const CameraModel* camera = rig.FindCamera(name);
    return camera ? static_cast<int>(camera - rig.cameras.data()) : -1;
  }
  int best = 0;
  for (int c = 1; c < static_cast<int>(rig.cameras.size()); ++c) {
    // The camera's optical axis in the rig frame: its z row; most nearly −z looks straight down.
    if (rig.cameras[c].cam_from_rig.rotation().row(2).z() < rig.cameras[best].cam_from_rig.rotation().row(2).z()) best = c;
  }
  return best;
}

// The widest angle the tile spans from a light, seen over the reference camera's views.
double TileSubtendsDeg(const SensorRays& rays, const std::vector<TileView>& tiles, const std::vector<LitView>& white,
                       int reference) {
  const RigModel& rig = rays.rig();
  double widest = 0;
  for (size_t v = 0; v < tiles.size(); ++v) {
    if (tiles[v].camera != reference || tiles[v].led < 0) continue;
    const LedModel& led = rig.leds[tiles[v].led];
    const CameraModel& camera = rig.cameras[reference];
    double low = 180, high = 0;
    const TurntablePoints points(rays, reference, white[v].lighting.turntable_deg);
    for (int pixel : tiles[v].pixels) {
      const auto p = points.At(pixel % camera.width, pixel / camera.width);
      const Eigen::Vector3d p_rig = rig.turntable.RigFromSample(white[v].lighting.turntable_deg) * *p;
      const double angle = RadToDeg(std::acos(std::clamp(led.axis.dot((p_rig - led.position_mm).normalized()), -1.0, 1.0)));
      low = std::min(low, angle);
      high = std::max(high, angle);
    }
    widest = std::max(widest, high - low);
  }
  return widest;
}

// Hat function k of `knots` equally spaced along the strip, at `along_mm` from its centre.
double Hat(const LinearLightModel& strip, int knots, int k, double along_mm) {
  const double t = (along_mm / strip.strip_length_mm + 0.5) * (knots - 1);
  return std::max(0.0, 1 - std::abs(t - k));
}

// One row of the profile's least squares: the shares w_k of a tile pixel's predicted
// irradiance by knot.
Eigen::VectorXd KnotShares(const LinearLightModel& strip, const StackObservation& observation, const Eigen::Vector3d& p,
                           int knots) {
  Eigen::VectorXd shares = Eigen::VectorXd::Zero(knots);
  for (int j = 0; j < static_cast<int>(observation.emitters.size()); ++j) {
    const double irradiance = Irradiance(observation.emitters[j], p);
    for (int k = 0; k < knots; ++k) shares[k] += Hat(strip, knots, k, strip.SegmentOffsetMm(j)) * irradiance;
  }
  const double total = shares.sum();
  return total > 0 ? Eigen::VectorXd(shares / total) : shares;
}

// The linear light's profile (the class comment in radiometry.h), times the rig's own.
Result<std::vector<double>> FitStripProfile(const SensorRays& rays, const std::vector<LitView>& white,
                                            const std::vector<TileView>& tiles, const std::vector<FlatField>& flats,
                                            const std::map<std::pair<int, int>, double>& scale, int knots) {
  const RigModel& rig = rays.rig();
  const LinearLightModel& strip = *rig.linear_light;
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(knots, knots);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(knots);
  long rows = 0;
  for (size_t v = 0; v < tiles.size(); ++v) {
    const TileView& tile = tiles[v];
    if (tile.led >= 0) continue;
    const CameraModel& camera = rig.cameras[tile.camera];
    LOOM_ASSIGN_OR_RETURN(const StackObservation observation, DescribeRigObservation(rig, tile.camera, white[v].lighting));
    if (static_cast<int>(observation.emitters.size()) != strip.segments) {
      return InternalError(white[v].source, "the linear light's view has " + std::to_string(observation.emitters.size()) +
                                                " point sources, its model " + std::to_string(strip.segments));
    }
    SensorModel calibrated = camera.sensor;
    calibrated.vignetting = flats[tile.camera].vignetting;
    calibrated.flat_field = flats[tile.camera].per_pixel;
    const double view_scale = scale.at({tile.camera, -1});
    const TurntablePoints points(rays, tile.camera, white[v].lighting.turntable_deg);
    for (size_t i = 0; i < tile.pixels.size(); ++i) {
      const int x = tile.pixels[i] % camera.width, y = tile.pixels[i] / camera.width;
      const auto p = points.At(x, y);
      const Eigen::VectorXd shares = KnotShares(strip, observation, *p, knots);
      const double measured = tile.ratio[i] * camera.sensor.RelativeResponse(x, y, camera.width, camera.height) /
                              (calibrated.RelativeResponse(x, y, camera.width, camera.height) * view_scale);
      normal += shares * shares.transpose();
      rhs += shares * measured;
      ++rows;
    }
  }
  if (rows == 0) return std::vector<double>();
  // The curvature penalty, at a weight that leaves the data's level and slope alone and bends
  // the profile only where the tile hardly tells knots apart.
  Eigen::MatrixXd curvature = Eigen::MatrixXd::Zero(std::max(0, knots - 2), knots);
  for (int k = 0; k + 2 < knots; ++k) curvature.row(k).segment(k, 3) << 1, -2, 1;
  normal += 1e-3 * normal.trace() * curvature.transpose() * curvature;
  const Eigen::VectorXd correction = normal.ldlt().solve(rhs);
  std::vector<double> profile;
  for (int k = 0; k < knots; ++k) {
    const double along_mm = (static_cast<double>(k) / (knots - 1) - 0.5) * strip.strip_length_mm;
    profile.push_back(strip.ProfileAt(along_mm) * correction[k]);
  }
  if (!std::ranges::all_of(profile, [](double p) { return std::isfinite(p) && p > 0; })) {
    return FailedPreconditionError("linear light", "its profile along the strip fitted to a value that is not positive");
  }
  return profile;
}

Status FitWhiteReference(const SensorRays& rays, const std::vector<LitView>& white, const RadiometryOptions& options,
                         Radiometry* radiometry, std::vector<TileView>* tiles) {
  const RigModel& rig = rays.rig();
  for (const LitView& view : white) {
    LOOM_ASSIGN_OR_RETURN(TileView tile, OnTile(rays, view, rig.white_reference.albedo, options.edge_px));
    tiles->push_back(std::move(tile));
  }
  const int reference = ReferenceCamera(rig, options.reference_camera);
  if (reference < 0) return NotFoundError("reference camera '" + options.reference_camera + "'", "not in rig '" + rig.name + "'");
  radiometry->reference_camera = rig.cameras[reference].name;
  // scale[(camera, light)] once each camera's flat field is out.
  std::map<std::pair<int, int>, double> scale;
  std::vector<FlatField> flats;
  for (int c = 0; c < static_cast<int>(rig.cameras.size()); ++c) {
    std::vector<const TileView*> led_views;  // the strip's profile would bend the flat field
    for (const TileView& tile : *tiles) {
      if (tile.camera == c && tile.led >= 0) led_views.push_back(&tile);
    }
    LOOM_ASSIGN_OR_RETURN(const FlatField flat, FitFlatField(rig.cameras[c], led_views, options.flat_smoothing_px));
    flats.push_back(flat);
    for (const TileView& tile : *tiles) {
      if (tile.camera == c) scale[{c, tile.led}] = ScaleOf(rig.cameras[c], tile, flat);
    }
  }
  std::vector<int> lights;
  for (int led = 0; led < static_cast<int>(rig.leds.size()); ++led) lights.push_back(led);
  if (rig.linear_light) lights.push_back(-1);
  std::map<int, double> light_scale;
  for (int light : lights) {
    const auto seen = scale.find({reference, light});
    if (seen == scale.end()) {
      return NotFoundError(LightName(light),
                           "has no white-reference view from the reference camera '" + rig.cameras[reference].name + "'");
    }
    light_scale[light] = seen->second;
  }
  for (int c = 0; c < static_cast<int>(rig.cameras.size()); ++c) {
    std::vector<double> ratios;
    for (int light : lights) {
      if (scale.contains({c, light})) ratios.push_back(scale[{c, light}] / light_scale[light]);
    }
    const CameraModel& camera = rig.cameras[c];
    CameraRadiometry result;
    result.name = camera.name;
    result.sensitivity_change = c == reference ? 1.0 : Median(ratios);
    result.sensitivity = camera.sensor.sensitivity * result.sensitivity_change;
    result.vignetting = flats[c].vignetting;
    result.flat_field_residual = flats[c].residual;
    result.flat_field = flats[c].per_pixel;
    result.flat_field_max = flats[c].per_pixel_max;
    for (const TileView& tile : *tiles) {
      if (tile.camera == c) result.tile_pixels = std::max(result.tile_pixels, static_cast<int>(tile.pixels.size()));
    }
    radiometry->cameras.push_back(result);
  }
  for (int light : lights) {
    LightRadiometry result;
    result.name = LightName(light);
    result.led = light;
    result.change = light_scale[light];
    const double nominal = light < 0 ? rig.linear_light->intensity_per_mm : rig.leds[light].intensity;
    result.intensity = nominal * result.change;
    double sum2 = 0;
    int cameras = 0;
    for (int c = 0; c < static_cast<int>(rig.cameras.size()); ++c) {
      if (!scale.contains({c, light})) continue;
      const double relative = scale[{c, light}] / (light_scale[light] * radiometry->cameras[c].sensitivity_change) - 1;
      sum2 += relative * relative;
      ++cameras;
    }
    result.camera_spread = std::sqrt(sum2 / cameras);
    if (light < 0) {
      LOOM_ASSIGN_OR_RETURN(result.profile, FitStripProfile(rays, white, *tiles, flats, scale, options.strip_profile_knots));
    }
    radiometry->lights.push_back(result);
  }
  radiometry->tile_subtends_deg = TileSubtendsDeg(rays, *tiles, white, reference);
  return Status::Ok();
}

// Per patch, the chart's radiance over the white reference's at the same pixels (inner 60 % of
// each patch, where both are valid).
Result<std::vector<double>> PatchRatios(const SensorRays& rays, const LitView& chart, const LitView& white,
                                        const TileView& tile) {
  const RigModel& rig = rays.rig();
  const CameraModel& camera = rig.cameras[chart.camera];
  const ColourChartModel& model = rig.colour_chart;
  std::vector<double> chart_sum(ColourChartModel::kPatches, 0), white_sum(ColourChartModel::kPatches, 0);
  const TurntablePoints points(rays, chart.camera, chart.lighting.turntable_deg);
  for (int pixel : tile.pixels) {
    const int x = pixel % camera.width, y = pixel / camera.width;
    const auto p = points.At(x, y);
    const int patch = model.PatchAt(p->x(), p->y());
    if (patch < 0) continue;
    const Eigen::Vector2d offset = p->head<2>() - model.PatchCentre(patch);
    if (offset.cwiseAbs().maxCoeff() > 0.3 * model.patch_mm) continue;
    const double c = chart.radiance.at(0, y, x), w = white.radiance.at(0, y, x);
    if (!std::isfinite(c) || !std::isfinite(w)) continue;
    chart_sum[patch] += c;
    white_sum[patch] += w;
  }
  std::vector<double> ratios;
  for (int patch = 0; patch < ColourChartModel::kPatches; ++patch) {
    if (!(white_sum[patch] > 0)) {
      return FailedPreconditionError(
          chart.source, "patch " + std::to_string(patch) + " of the colour chart is not seen on the white reference");
    }
    ratios.push_back(chart_sum[patch] / white_sum[patch]);
  }
  return ratios;
}

// The wheel and slot in front of a chart view's LED.
Result<std::pair<int, int>> FilterOf(const RigModel& rig, const LitView& view) {
  if (view.lighting.leds.size() == 1) {
    for (const auto& [wheel, slot] : view.lighting.filter_slots) {
      if (rig.filter_wheels[wheel].led == view.lighting.leds.front().first && !rig.filter_wheels[wheel].filters[slot].open) {
        return std::pair{wheel, slot};
      }
    }
  }
  return InvalidArgumentError(view.source, "a colour-chart view must be lit by one LED through a band-pass filter");
}

Status FitColour(const SensorRays& rays, const std::vector<LitView>& white, const std::vector<TileView>& tiles,
                 const std::vector<LitView>& chart, Radiometry* radiometry) {
  const RigModel& rig = rays.rig();
  const double albedo = rig.white_reference.albedo;
  // (wheel, slot) → per camera view, the readings (albedo units) of the 24 patches.
  std::map<std::pair<int, int>, std::vector<std::vector<double>>> readings;
  for (const LitView& view : chart) {
    LOOM_ASSIGN_OR_RETURN(const auto filter, FilterOf(rig, view));
    const int led = view.lighting.leds.front().first;
    size_t w = 0;
    while (w < white.size() && !(tiles[w].camera == view.camera && tiles[w].led == led)) ++w;
    if (w == white.size()) {
      return NotFoundError(view.source, "has no white-reference view of the same camera and LED to compare with");
    }
    LOOM_ASSIGN_OR_RETURN(std::vector<double> ratios, PatchRatios(rays, view, white[w], tiles[w]));
    for (double& r : ratios) r *= albedo;
    readings[filter].push_back(std::move(ratios));
  }
  for (const auto& [filter, views] : readings) {
    const auto [wheel, slot] = filter;
    Eigen::MatrixXd a(views.size() * ColourChartModel::kPatches, 3);
    Eigen::VectorXd b(a.rows());
    for (size_t v = 0; v < views.size(); ++v) {
      for (int p = 0; p < ColourChartModel::kPatches; ++p) {
        a.row(v * ColourChartModel::kPatches + p) = ColourChartModel::Albedo(p).transpose();
        b(v * ColourChartModel::kPatches + p) = views[v][p];
      }
    }
    FilterRadiometry result;
    result.wheel = rig.filter_wheels[wheel].name;
    result.slot = slot;
    FilterModel nominal = rig.filter_wheels[wheel].filters[slot];
    result.center_nm = nominal.center_nm;
    nominal.measured_weights.reset();
    result.nominal_weights = FilterWeights(nominal);
    result.weights = a.colPivHouseholderQr().solve(b);
    result.fit_residual = std::sqrt(((a * result.weights - b).array() / b.array()).square().mean());
    radiometry->filters.push_back(result);
  }
  // Each wheel's colour matrix, checked on the chart with the readings averaged over cameras.
  for (int w = 0; w < static_cast<int>(rig.filter_wheels.size()); ++w) {
    WheelColour colour;
    colour.wheel = rig.filter_wheels[w].name;
    std::vector<Eigen::Vector3d> weights;
    for (const FilterRadiometry& f : radiometry->filters) {
      if (f.wheel == colour.wheel) {
        colour.slots.push_back(f.slot);
        weights.push_back(f.weights);
      }
    }
    if (weights.size() < 3) continue;  // fewer than three bands cannot give three colours
    Eigen::MatrixXd bands(weights.size(), 3);
    for (size_t k = 0; k < weights.size(); ++k) bands.row(k) = weights[k].transpose();
    colour.colour_matrix = bands.completeOrthogonalDecomposition().pseudoInverse();
    double sum2 = 0;
    for (int p = 0; p < ColourChartModel::kPatches; ++p) {
      Eigen::VectorXd reading(weights.size());
      for (size_t k = 0; k < weights.size(); ++k) {
        const auto& views = readings[{w, colour.slots[k]}];
        double sum = 0;
        for (const auto& v : views) sum += v[p];
        reading(k) = sum / views.size();
      }
      const Eigen::Vector3d error = colour.colour_matrix * reading - ColourChartModel::Albedo(p);
      sum2 += error.squaredNorm();
      colour.chart_max = std::max(colour.chart_max, error.cwiseAbs().maxCoeff());
    }
    colour.chart_rms = std::sqrt(sum2 / (3 * ColourChartModel::kPatches));
    radiometry->wheels.push_back(colour);
  }
  return Status::Ok();
}

// The tile for the linearity check: the view's bright pixels, away from the tile's edge.
std::vector<uint8_t> BrightPixels(const Image& radiance, int edge_px) {
  std::vector<double> finite;
  for (float v : radiance.channel(0)) {
    if (std::isfinite(v)) finite.push_back(v);
  }
  std::vector<uint8_t> mask(radiance.pixel_count(), 0);
  if (finite.empty()) return mask;
  const double threshold = 0.4 * Percentile(finite, 0.9);
  cv::Mat bright(radiance.height(), radiance.width(), CV_8U, mask.data());
  for (size_t i = 0; i < mask.size(); ++i) mask[i] = radiance.channel(0)[i] > threshold;
  cv::erode(bright, bright, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * edge_px + 1, 2 * edge_px + 1)));
  return mask;
}

}  // namespace

Result<Radiometry> FitRadiometry(const RigModel& rig, const std::vector<LitView>& white, const std::vector<LitView>& chart,
                                 const RadiometryOptions& options) {
  LOOM_RETURN_IF_ERROR(options.Check());
  Radiometry radiometry;
  radiometry.white_albedo = rig.white_reference.albedo;
  std::vector<TileView> tiles;
  const SensorRays rays(rig);
  LOOM_RETURN_IF_ERROR(FitWhiteReference(rays, white, options, &radiometry, &tiles));
  LOOM_RETURN_IF_ERROR(FitColour(rays, white, tiles, chart, &radiometry));
  return radiometry;
}

namespace {

using LinearityByCamera = std::map<std::string, Linearity>;

// Each camera's worst linearity over the white-reference brackets (their raw frames; the
// merged views say where the tile is).
Result<LinearityByCamera> MeasureCameraLinearity(const ScanRadiance& scan, const std::vector<LitView>& white,
                                                 const RadiometryOptions& options) {
  LinearityByCamera linearity;
  for (const LitView& view : white) {
    const std::string& camera = scan.rig().cameras[view.camera].name;
    LOOM_ASSIGN_OR_RETURN(const std::vector<scan::RawFrame> bracket, scan.Bracket(view.step, camera));
    LOOM_ASSIGN_OR_RETURN(const Linearity measured, MeasureLinearity(bracket, scan.NoiseOf(camera, bracket.front().metadata.gain),
                                                                     BrightPixels(view.radiance, options.edge_px)));
    Linearity& worst = linearity[camera];
    worst.deviation = std::max(worst.deviation, measured.deviation);
    worst.max_dn = std::max(worst.max_dn, measured.max_dn);
    worst.pairs += measured.pairs;
  }
  return linearity;
}

}  // namespace

Status RadiometryOptions::Check() const {
  std::vector<std::string> problems;
  if (edge_px < 0 || edge_px > 1000) problems.push_back("edge_px must be in [0, 1000]");
  if (!(flat_smoothing_px >= 0 && flat_smoothing_px <= 50)) problems.push_back("flat_smoothing_px must be in [0, 50]");
  if (strip_profile_knots < 2 || strip_profile_knots > 64) problems.push_back("strip_profile_knots must be in [2, 64]");
  return ProblemsStatus("RadiometryOptions", problems);
}

Result<Radiometry> CalibrateRadiometry(const ScanRadiance& scan, const RadiometryOptions& options) {
  LOOM_RETURN_IF_ERROR(options.Check());
  LOOM_ASSIGN_OR_RETURN(const std::vector<LitView> white, scan.LitViews(StepKind::kWhiteReference));
  LOOM_ASSIGN_OR_RETURN(const std::vector<LitView> chart, scan.LitViews(StepKind::kColourChart));
  if (white.empty()) {
    return FailedPreconditionError("scan " + scan.directory().string(),
                                   "has no white-reference steps: radiometry needs a calibration scan (loom scan --calibration)");
  }
  LOOM_ASSIGN_OR_RETURN(Radiometry radiometry, FitRadiometry(scan.rig(), white, chart, options));
  LOOM_ASSIGN_OR_RETURN(LinearityByCamera linearity, MeasureCameraLinearity(scan, white, options));
  for (CameraRadiometry& camera : radiometry.cameras) {
    const SensorNoise dark = scan.NoiseOf(camera.name, 0);
    camera.black_dn = dark.black_dn;
    camera.read_noise_dn = dark.read_noise_dn;
    const Linearity& measured = linearity[camera.name];
    camera.linearity_deviation = measured.pairs > 0 ? measured.deviation : std::numeric_limits<double>::quiet_NaN();
    camera.linearity_max_dn = measured.max_dn;
  }
  return radiometry;
}

void ApplyRadiometry(const Radiometry& radiometry, RigModel* rig) {
  for (const CameraRadiometry& calibrated : radiometry.cameras) {
    for (CameraModel& camera : rig->cameras) {
      if (camera.name != calibrated.name) continue;
      camera.sensor.sensitivity = calibrated.sensitivity;
      camera.sensor.vignetting = calibrated.vignetting;
      camera.sensor.flat_field = calibrated.flat_field;
    }
  }
  for (const LightRadiometry& light : radiometry.lights) {
    if (light.led >= 0 && light.led < static_cast<int>(rig->leds.size())) rig->leds[light.led].intensity = light.intensity;
    if (light.led < 0 && rig->linear_light) {
      rig->linear_light->intensity_per_mm = light.intensity;
      if (!light.profile.empty()) rig->linear_light->profile = light.profile;
    }
  }
  for (const FilterRadiometry& filter : radiometry.filters) {
    for (FilterWheelModel& wheel : rig->filter_wheels) {
      if (wheel.name == filter.wheel && filter.slot < static_cast<int>(wheel.filters.size())) {
        wheel.filters[filter.slot].measured_weights = filter.weights;
      }
    }
  }
}

}  // namespace loom::calibration
