#include "sim/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <thread>

#include "core/check.h"
#include "core/heightfield.h"
#include "core/spectra.h"
#include "fitting/model/svbrdf_maps.h"
#include "sim/internal/noise.h"

namespace loom::sim {
namespace {

constexpr double kHolderAlbedo = 0.05;  // the matte black sample holder

int ThreadCount(int requested) {
  return requested > 0 ? requested : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

// Runs body(y) for every row, rows interleaved over threads; rows not yet started are skipped
// once `stop_requested` (if set) returns true.
template <typename Body>
void ForEachRow(int rows, int threads, Body body, const std::function<bool()>& stop_requested = {}) {
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&, t] {
      for (int y = t; y < rows && !(stop_requested && stop_requested()); y += threads) body(y);
    });
  }
  for (std::thread& worker : workers) worker.join();
}

double StandardNormal(uint64_t seed, uint64_t index, uint64_t stream) {
  const double u1 = std::max(internal::Hash01(seed, index, stream), 1e-300);
  const double u2 = internal::Hash01(seed, index, stream + 1);
  return std::sqrt(-2 * std::log(u1)) * std::cos(2 * kPi * u2);
}

// Poisson-distributed electron count: exact (Knuth) for small means, normal beyond.
double ShotNoise(double mean, uint64_t seed, uint64_t index) {
  if (mean <= 0) return 0;
  if (mean > 30) return std::max(0.0, mean + std::sqrt(mean) * StandardNormal(seed, index, 10));
  const double limit = std::exp(-mean);
  double product = internal::Hash01(seed, index, 20);
  int count = 0;
  while (product > limit && count < 200) {
    ++count;
    product *= internal::Hash01(seed, index, 21 + count);
  }
  return count;
}

}  // namespace

struct Scene::Surface {
  fitting::WardParams<double> params;
  BeyondGd10 beyond;
  Eigen::Matrix3d world_from_local = Eigen::Matrix3d::Identity();
};

namespace {

// The pattern's grey level (0..1) at subpixel (u, v), bilinear between pixel centres; u, v
// within [0, width − 1] × [0, height − 1].
double ProjectedLevel(const ProjectedImage& image, double u, double v) {
  const int u0 = std::min(static_cast<int>(u), std::max(0, image.width - 2));
  const int v0 = std::min(static_cast<int>(v), std::max(0, image.height - 2));
  const int u1 = std::min(u0 + 1, image.width - 1);
  const int v1 = std::min(v0 + 1, image.height - 1);
  const double fu = u - u0;
  const double fv = v - v0;
  const auto at = [&](int x, int y) { return image.pixels[static_cast<size_t>(y) * image.width + x] / 255.0; };
  return (1 - fv) * ((1 - fu) * at(u0, v0) + fu * at(u1, v0)) + fv * ((1 - fu) * at(u0, v1) + fu * at(u1, v1));
}

}  // namespace

Scene::Scene(RigModel rig, Material material) : rig_(std::move(rig)), material_(std::move(material)) {
  const int w = material_.width();
  const int h = material_.height();
  const std::optional<int> height_channel = material_.maps.FindChannel(fitting::kHeightChannel);
  std::vector<double> heights(static_cast<size_t>(w) * h, 0.0);
  if (height_channel) {
    const auto plane = material_.maps.channel(*height_channel);
    std::copy(plane.begin(), plane.end(), heights.begin());
  }
  heightmap_ = Heightmap(std::vector<float>(heights.begin(), heights.end()), w, h, material_.pixel_mm);
  double blur_mm = 1.0;
  if (auto it = material_.provenance.find("loom.geometric_blur_mm");
      it != material_.provenance.end() && std::holds_alternative<double>(it->second)) {
    blur_mm = std::get<double>(it->second);
  }
  const std::vector<Eigen::Vector3d> normals = GeometricNormals(heights, w, h, material_.pixel_mm, blur_mm);
  frames_.resize(normals.size());
  for (size_t i = 0; i < normals.size(); ++i) frames_[i] = WorldFromLocal(normals[i], Eigen::Vector3d::UnitX());
  panchromatic_ = PanchromaticWeights();
  for (const FilterWheelModel& wheel : rig_.filter_wheels) {
    std::vector<Eigen::Vector3d>& slots = filter_weights_.emplace_back();
    for (const FilterModel& filter : wheel.filters) slots.push_back(FilterWeights(filter));
  }
  Result<std::optional<BeyondLayout>> beyond = FindBeyondChannels(material_.maps);
  LOOM_CHECK(beyond.ok()) << material_.name << ": " << beyond.status().ToString() << " (ReadMaterial refuses such files)";
  beyond_ = *beyond;
}

std::optional<int> Scene::MapPixel(double x_mm, double y_mm) const {
  const int x = static_cast<int>(std::floor(x_mm / material_.pixel_mm + material_.width() / 2.0));
  const int y = static_cast<int>(std::floor(y_mm / material_.pixel_mm + material_.height() / 2.0));
  if (x < 0 || y < 0 || x >= material_.width() || y >= material_.height()) return std::nullopt;
  return y * material_.width() + x;
}

double Scene::HeightAt(double x_mm, double y_mm) const { return heightmap_.HeightAt(x_mm, y_mm); }

Eigen::Vector3d Scene::GeometricNormalAt(double x_mm, double y_mm) const {
  const std::optional<int> pixel = MapPixel(x_mm, y_mm);
  return pixel ? Eigen::Vector3d(frames_[*pixel].col(2)) : Eigen::Vector3d::UnitZ();
}

std::optional<Eigen::Vector3d> Scene::Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) const {
  if (direction.z() >= 0) return std::nullopt;
  const Eigen::Vector3d hit = heightmap_.FirstHit(origin, direction);
  if (hit.head<2>().norm() > rig_.sample_holder_diameter_mm / 2 && !MapPixel(hit.x(), hit.y())) return std::nullopt;
  return hit;
}

bool Scene::Shadowed(const Eigen::Vector3d& p, const Eigen::Vector3d& light) const {
  // A flat material casts no shadow (a light below its horizon gets cos ≤ 0 from the BRDF).
  return heightmap_.max_height_mm() > 0 && heightmap_.Shadowed(p, light);
}

double Scene::PointSourceRadiance(const ShadingPoint& point, const Eigen::Vector3d& light, double intensity,
                                  const Eigen::Vector3d& weights, const Eigen::Vector3d& v_local, bool shadows) const {
  if (intensity <= 0) return 0;
  const Eigen::Vector3d to_light = light - point.p;
  const double distance2 = to_light.squaredNorm();
  const double reflected =
      point.reflectance.EvaluateCos(point.local_from_world * (to_light / std::sqrt(distance2)), v_local, weights);
  if (reflected <= 0) return 0;
  if (shadows && Shadowed(point.p, light)) return 0;
  return intensity / distance2 * reflected;
}

Scene::PlacedState Scene::Place(const SceneState& state) const {
  const Rigid3d rig_from_sample = rig_.turntable.RigFromSample(state.turntable_deg);
  PlacedState placed;
  placed.rig_from_sample = rig_from_sample;
  placed.sample_from_rig = rig_from_sample.inverse();
  if (rig_.projector) placed.projector_in_sample = placed.sample_from_rig * rig_.projector->proj_from_rig.inverse().translation();
  for (const LitLed& lit : state.leds) {
    if (lit.led < 0 || lit.led >= static_cast<int>(rig_.leds.size())) continue;
    const LedModel& led = rig_.leds[lit.led];
    Eigen::Vector3d weights = panchromatic_;
    for (size_t w = 0; w < rig_.filter_wheels.size(); ++w) {
      const FilterWheelModel& wheel = rig_.filter_wheels[w];
      const auto slot = state.filter_slots.find(static_cast<int>(w));
      if (wheel.led == lit.led && slot != state.filter_slots.end() && slot->second >= 0 &&
          slot->second < static_cast<int>(wheel.filters.size())) {
        weights = filter_weights_[w][slot->second];
      }
    }
    placed.leds.push_back({&led, lit.current_ma, placed.sample_from_rig * led.position_mm, weights});
  }
  if (rig_.linear_light && state.linear_light_on && state.linear_light_intensity > 0) {
    // The strip as `segments` point sources, each emitting cos^n about the strip's normal.
    const LinearLightModel& strip = *rig_.linear_light;
    const Eigen::Vector3d centre = strip.StripCentre(state.linear_light_mm);
    placed.strip_normal = strip.StripNormal(state.linear_light_mm);
    const double segment_mm = strip.strip_length_mm / strip.segments;
    for (int k = 0; k < strip.segments; ++k) {
      const double along_mm = strip.SegmentOffsetMm(k);
      const Eigen::Vector3d source = centre + strip.sweep_axis * along_mm;
      placed.strip.push_back({source, placed.sample_from_rig * source,
                              strip.intensity_per_mm * strip.ProfileAt(along_mm) * segment_mm * state.linear_light_intensity});
    }
  }
  return placed;
}

double Scene::RadianceAt(const Eigen::Vector3d& p, const Eigen::Vector3d& eye, const SceneState& state, bool shadows) const {
  return RadianceAt(ShadeAt(p), eye, state, Place(state), shadows);
}

Scene::ShadingPoint Scene::ShadeAt(const Eigen::Vector3d& p) const {
  Surface surface;
  if (const std::optional<int> pixel = MapPixel(p.x(), p.y())) {
    const int x = *pixel % material_.width(), y = *pixel / material_.width();
    surface.params = fitting::GetParams(material_.maps, x, y);
    if (beyond_) surface.beyond = GetBeyond(material_.maps, *beyond_, x, y);
    surface.world_from_local = frames_[*pixel];
  } else {
    surface.params.a_d = Eigen::Vector3d::Constant(kHolderAlbedo);
    surface.params.a_s = Eigen::Vector3d::Zero();
  }
  return {p, Reflectance(surface.params, surface.beyond), surface.world_from_local.transpose()};
}

double Scene::RadianceAt(const ShadingPoint& point, const Eigen::Vector3d& eye, const SceneState& state,
                         const PlacedState& placed, bool shadows) const {
  const Eigen::Vector3d& p = point.p;
  const Eigen::Vector3d v_local = point.local_from_world * (eye - p).normalized();
  const Eigen::Vector3d p_in_rig = placed.rig_from_sample * p;
  double radiance = 0;
  for (const PlacedState::Led& led : placed.leds) {
    radiance += PointSourceRadiance(point, led.in_sample, led.model->IntensityTowards(p_in_rig, led.current_ma), led.weights,
                                    v_local, shadows);
  }
  for (const PlacedState::StripSource& source : placed.strip) {
    const double c = placed.strip_normal.dot((p_in_rig - source.in_rig).normalized());
    if (c <= 0) continue;
    const double intensity = source.intensity * CosinePower(c, rig_.linear_light->falloff_exponent);
    radiance += PointSourceRadiance(point, source.in_sample, intensity, panchromatic_, v_local, shadows);
  }
  if (rig_.projector && state.projector_image) {
    // The grey level the projector throws on p. Its lens is slightly out of focus, as real
    // structured-light projectors are set up: the pattern blends linearly between pixel centres
    // (in focus, a phase pattern would be a staircase of whole pixels).
    const ProjectorModel& projector = *rig_.projector;
    const ProjectedImage& image = *state.projector_image;
    const Eigen::Vector3d p_in_projector = projector.proj_from_rig * p_in_rig;
    if (p_in_projector.z() > 0) {
      const Eigen::Vector3d uv = projector.K * (p_in_projector / p_in_projector.z());
      const int columns = std::min(image.width, projector.width);
      const int rows = std::min(image.height, projector.height);
      if (uv.x() > -0.5 && uv.y() > -0.5 && uv.x() < columns - 0.5 && uv.y() < rows - 0.5) {
        const double level = ProjectedLevel(image, std::clamp(uv.x(), 0.0, columns - 1.0), std::clamp(uv.y(), 0.0, rows - 1.0));
        radiance += PointSourceRadiance(point, placed.projector_in_sample, projector.max_intensity * level, panchromatic_,
                                        v_local, shadows);
      }
    }
  }
  return radiance;
}

Status RenderOptions::Check() const {
  std::vector<std::string> problems;
  if (supersampling < 1 || supersampling > 16) problems.push_back("supersampling must be in [1, 16]");
  if (threads < 0) problems.push_back("threads must be ≥ 0");
  if (window.x < 0 || window.y < 0 || window.width < 0 || window.height < 0 || (window.width > 0) != (window.height > 0)) {
    problems.push_back("window must have x, y ≥ 0 and both or neither of width and height");
  }
  return ProblemsStatus("RenderOptions", problems);
}

bool CameraHits::Serve(int camera_index, double turntable, const RenderOptions& options) const {
  return camera == camera_index && turntable_deg == turntable && window == options.window &&
         supersampling == options.supersampling;
}

CameraHits Scene::TraceCamera(int camera_index, double turntable_deg, const RenderOptions& options) const {
  const Status checked = options.Check();
  LOOM_CHECK(checked.ok()) << checked.ToString();
  const CameraModel& camera = rig_.cameras.at(camera_index);
  const Rigid3d sample_from_rig = rig_.turntable.RigFromSample(turntable_deg).inverse();
  const Eigen::Matrix3d sample_from_cam = sample_from_rig.linear() * camera.cam_from_rig.linear().transpose();
  const SensorWindow& window = options.window;
  const bool whole = window.width == 0;
  LOOM_CHECK(whole || (window.x + window.width <= camera.width && window.y + window.height <= camera.height))
      << "window outside camera '" << camera.name << "'";
  CameraHits hits{.camera = camera_index,
                  .turntable_deg = turntable_deg,
                  .window = window,
                  .supersampling = options.supersampling,
                  .width = whole ? camera.width : window.width,
                  .height = whole ? camera.height : window.height,
                  .eye = sample_from_rig * camera.CentreInRig(),
                  .points = {}};
  const int x0 = whole ? 0 : window.x, y0 = whole ? 0 : window.y;
  const int ss = options.supersampling;
  hits.points.resize(static_cast<size_t>(hits.width) * hits.height * ss * ss);
  ForEachRow(
      hits.height, ThreadCount(options.threads),
      [&](int row) {
        Eigen::Vector3d* point = hits.points.data() + static_cast<size_t>(row) * hits.width * ss * ss;
        for (int column = 0; column < hits.width; ++column) {
          for (int sy = 0; sy < ss; ++sy) {
            for (int sx = 0; sx < ss; ++sx) {
              const Eigen::Vector2d pixel(x0 + column + (sx + 0.5) / ss - 0.5, y0 + row + (sy + 0.5) / ss - 0.5);
              const std::optional<Eigen::Vector3d> hit = Intersect(hits.eye, sample_from_cam * camera.Unproject(pixel));
              *point++ = hit ? *hit : Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
            }
          }
        }
      },
      options.stop_requested);
  return hits;
}

bool Scene::Dark(const SceneState& state) const {
  const PlacedState placed = Place(state);
  return placed.strip.empty() && !(rig_.projector && state.projector_image) &&
         std::ranges::none_of(placed.leds, [](const PlacedState::Led& led) { return led.current_ma > 0; });
}

Image Scene::RenderRadiance(int camera_index, const SceneState& state, const RenderOptions& options) const {
  return RenderRadiance(TraceCamera(camera_index, state.turntable_deg, options), state, options);
}

Image Scene::RenderRadiance(const CameraHits& hits, const SceneState& state, const RenderOptions& options) const {
  const Status checked = options.Check();
  LOOM_CHECK(checked.ok()) << checked.ToString();
  LOOM_CHECK(hits.Serve(hits.camera, state.turntable_deg, options)) << "camera hits traced for another render";
  Image radiance(hits.width, hits.height, {"L"});
  const int rays = options.supersampling * options.supersampling;
  const PlacedState placed = Place(state);
  ForEachRow(
      radiance.height(), ThreadCount(options.threads),
      [&](int row) {
        const Eigen::Vector3d* point = hits.points.data() + static_cast<size_t>(row) * hits.width * rays;
        for (int column = 0; column < radiance.width(); ++column) {
          double sum = 0;
          for (int ray = 0; ray < rays; ++ray, ++point) {
            if (!std::isnan(point->x())) sum += RadianceAt(ShadeAt(*point), hits.eye, state, placed, options.shadows);
          }
          radiance.at(0, row, column) = static_cast<float>(sum / rays);
        }
      },
      options.stop_requested);
  return radiance;
}

namespace {

// CaptureRaw of `radiance` lying at (x0, y0) on a sensor_width × sensor_height sensor.
std::vector<uint16_t> CaptureRawAt(const Image& radiance, const SensorModel& sensor, const CaptureSettings& settings,
                                   uint64_t noise_seed, bool noise, int x0, int y0, int sensor_width, int sensor_height) {
  const int w = radiance.width();
  const int h = radiance.height();
  const double max_dn = (1 << sensor.adc_bits) - 1;
  const double gain = std::pow(10.0, settings.gain_db / 20);
  const double dn_per_electron = gain / sensor.ElectronsPerDn();
  std::vector<uint16_t> raw(static_cast<size_t>(w) * h);
  // Every pixel's noise comes from its own hash, so rows run on every core and give the same
  // frame: a quarter of a calibration scan's time had been one core drawing noise for each
  // exposure of a bracket (perf). Small frames are not worth the threads.
  const int threads = static_cast<size_t>(w) * h >= 65536 ? ThreadCount(0) : 1;
  ForEachRow(h, threads, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t out = static_cast<size_t>(y) * w + x;
      // The noise and vignetting of this pixel's place on the sensor.
      const uint64_t index = static_cast<uint64_t>(y0 + y) * sensor_width + (x0 + x);
      const double vignetting = sensor.RelativeResponse(x0 + x, y0 + y, sensor_width, sensor_height);
      const double mean_e = std::max(0.0, radiance.at(0, y, x) * sensor.sensitivity * settings.exposure_us * 1e-6 * vignetting);
      double electrons = noise ? ShotNoise(mean_e, noise_seed, index) : mean_e;
      if (electrons >= sensor.full_well_e) {  // a full well reads as the ADC's top, noise-free
        raw[out] = static_cast<uint16_t>(max_dn);
        continue;
      }
      double dn = sensor.dark_offset_dn + electrons * dn_per_electron;
      if (noise) dn += sensor.read_noise_e * dn_per_electron * StandardNormal(noise_seed, index, 1);
      raw[out] = static_cast<uint16_t>(std::clamp(std::round(dn), 0.0, max_dn));
    }
  });
  return raw;
}

}  // namespace

std::vector<uint16_t> CaptureRaw(const Image& radiance, const SensorModel& sensor, const CaptureSettings& settings,
                                 uint64_t noise_seed, bool noise) {
  return CaptureRawAt(radiance, sensor, settings, noise_seed, noise, 0, 0, radiance.width(), radiance.height());
}

std::vector<uint16_t> CaptureRaw(const Image& radiance, const SensorModel& sensor, const CaptureSettings& settings,
                                 uint64_t noise_seed, const SensorWindow& window, int sensor_width, int sensor_height) {
  LOOM_CHECK(window.x + radiance.width() <= sensor_width && window.y + radiance.height() <= sensor_height)
      << "a window outside its sensor";
  return CaptureRawAt(radiance, sensor, settings, noise_seed, true, window.x, window.y, sensor_width, sensor_height);
}

Result<Image> RenderCameraFrame(const Scene& scene, const std::string& camera, const SceneState& state,
                                const CaptureSettings& settings, uint64_t noise_seed) {
  const std::vector<CameraModel>& cameras = scene.rig().cameras;
  const auto found = std::find_if(cameras.begin(), cameras.end(), [&](const CameraModel& c) { return c.name == camera; });
  if (found == cameras.end()) return NotFoundError("camera '" + camera + "'", "not in rig '" + scene.rig().name + "'");
  const int led_count = static_cast<int>(scene.rig().leds.size());
  for (const LitLed& lit : state.leds) {
    if (lit.led < 0 || lit.led >= led_count) {
      return InvalidArgumentError("LED " + std::to_string(lit.led),
                                  "not in rig '" + scene.rig().name + "' (LEDs 0 to " + std::to_string(led_count - 1) + ")");
    }
  }
  const Image radiance = scene.RenderRadiance(static_cast<int>(found - cameras.begin()), state);
  const std::vector<uint16_t> raw = CaptureRaw(radiance, found->sensor, settings, noise_seed);
  Image frame(radiance.width(), radiance.height(), {"radiance", "raw"});
  std::copy(radiance.channel(0).begin(), radiance.channel(0).end(), frame.channel(0).begin());
  std::copy(raw.begin(), raw.end(), frame.channel(1).begin());
  return frame;
}

}  // namespace loom::sim
