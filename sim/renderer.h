#pragma once
// The renderer of the virtual rig: the raw frame a camera records for a rig state.
//
// Radiance (RenderRadiance): for each camera pixel, supersampling² rays through the lens model
// (distortion included) into the scene: the material's heightfield on the turntable (rotated by
// the table angle) on a dark sample holder. At the hit point: the GD10 Ward BRDF with that map
// pixel's parameters in its local geometric frame; every lit LED adds I(θ)/d² · f_r · cos, with
// a cast-shadow test against the heightfield; colour through the LED's filter (spectra.h).
// Sensor (CaptureRaw): radiance × sensitivity × exposure × vignetting → electrons, shot noise,
// full-well clipping, gain, read noise, dark offset, ADC quantisation and saturation.
// Deterministic: the noise of pixel (x, y) comes from (seed, x, y) only, whatever the threads.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "core/heightmap.h"
#include "core/image.h"
#include "core/rig_model.h"
#include "core/status.h"
#include "fitting/model/ward_gd10.h"
#include "sim/material.h"
#include "sim/reflectance.h"

namespace loom::sim {

struct LitLed {
  int led = 0;
  double current_ma = 0;
  bool operator==(const LitLed&) const = default;
};

// An 8-bit grey image the projector shows.
struct ProjectedImage {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> pixels;  // row-major
};

// What the devices are doing, as the renderer needs it.
struct SceneState {
  std::vector<LitLed> leds = {};
  std::map<int, int> filter_slots = {};  // filter wheel index (in RigModel) → slot
  double turntable_deg = 0;
  bool linear_light_on = false;
  double linear_light_mm = 0;  // carriage position
  double linear_light_intensity = 1;
  std::shared_ptr<const ProjectedImage> projector_image = nullptr;  // null: projector dark
  // The same image is the same pointer: a pattern shown anew compares unequal (conservative).
  bool operator==(const SceneState&) const = default;
};

struct CaptureSettings {
  double exposure_us = 10000;
  double gain_db = 0;
};

// Pixels [x, x + width) × [y, y + height) of a camera's sensor, as a GenICam region of interest;
// width 0: the whole sensor.
struct SensorWindow {
  int x = 0;
  int y = 0;
  int width = 0;
  int height = 0;
  bool operator==(const SensorWindow&) const = default;
};

struct RenderOptions {
  int supersampling = 2;  // rays per pixel per axis
  bool shadows = true;
  int threads = 0;           // 0 = one per core
  SensorWindow window = {};  // only these pixels are rendered (the image is the window's size)
  // Polled before each row of a trace or render, if set: once it returns true the rows not yet
  // started are skipped, and the result is incomplete — its caller must discard it. So that a
  // simulated camera under a rig's interrupt handler stops a long frame at SIGTERM or Ctrl-C.
  std::function<bool()> stop_requested = {};
  Status Check() const;  // every problem, naming the field (RenderRadiance throws on one)
};

// Where a camera's rays meet the scene at one turntable angle: what every frame the camera takes
// at that angle shares, whatever the lights. A scan renders a frame per step and keeps the angle
// for dozens of steps, and marching each ray into the heightfield again was two thirds of a
// one-LED frame (bench_sim: 77 ms traced, 27 ms from hits).
struct CameraHits {
  int camera = -1;
  double turntable_deg = 0;
  SensorWindow window;
  int supersampling = 0;
  int width = 0;  // of the rendered image (the window's, or the sensor's)
  int height = 0;
  Eigen::Vector3d eye = Eigen::Vector3d::Zero();  // the camera's centre, sample frame
  // Per ray, pixel by pixel (row-major), each pixel's supersampling² rays row by row; a ray that
  // misses the sample and its holder has NaN coordinates.
  std::vector<Eigen::Vector3d> points;
  // Whether these are the hits a render of `camera` at `turntable_deg` with `options` needs.
  bool Serve(int camera, double turntable_deg, const RenderOptions& options) const;
};

class Scene {
 public:
  // The material lies on the turntable, centred on its axis.
  Scene(RigModel rig, Material material);

  const RigModel& rig() const { return rig_; }
  const Material& material() const { return material_; }

  // Radiance (one channel, radiance units) seen by camera `camera` (index into rig().cameras).
  Image RenderRadiance(int camera, const SceneState& state, const RenderOptions& options = {}) const;
  // The same from hits traced before (TraceCamera), which must serve this render (CHECKed):
  // the same image, bit for bit.
  Image RenderRadiance(const CameraHits& hits, const SceneState& state, const RenderOptions& options) const;
  CameraHits TraceCamera(int camera, double turntable_deg, const RenderOptions& options = {}) const;
  // Whether no light reaches the sample under `state` (no LED driven, the linear light and the
  // projector off): every render of it is 0, so a dark frame needs no rays traced.
  bool Dark(const SceneState& state) const;

  // Radiance leaving the sample at sample-frame point `p` (on the surface) towards `eye` (a
  // sample-frame position), under `state`; also used by tests and by the fast path.
  double RadianceAt(const Eigen::Vector3d& p, const Eigen::Vector3d& eye, const SceneState& state, bool shadows) const;

  // RadianceAt in parts, for renders of many points or many states: what a state gives every
  // point (the turntable's pose, its lights placed in the sample frame) and what a point keeps
  // under every state (its reflectance and frame), each computed once. Per ray, the turntable's
  // pose was a sixth of a frame from hits (27.2 → 22.6 ms); per observation, the pose and the
  // point's reflectance a third of a fast-path stack (1.38 → 0.92 s; bench_sim); per ray, a
  // 29-LED target frame had looked up every LED's filter wheel slot and moved it again.
  struct PlacedState {
    Rigid3d rig_from_sample;
    Rigid3d sample_from_rig;
    Eigen::Vector3d projector_in_sample = Eigen::Vector3d::Zero();  // its centre, if the rig has one
    struct Led {
      const LedModel* model;
      double current_ma;
      Eigen::Vector3d in_sample;
      Eigen::Vector3d weights;  // through its filter, if one is in front of it
    };
    std::vector<Led> leds;  // the lit ones
    struct StripSource {
      Eigen::Vector3d in_rig;
      Eigen::Vector3d in_sample;
      double intensity;  // before the strip's falloff towards a point
    };
    std::vector<StripSource> strip;  // the linear light's point sources, when it is on
    Eigen::Vector3d strip_normal = Eigen::Vector3d::Zero();
  };
  struct ShadingPoint {
    Eigen::Vector3d p;
    Reflectance reflectance;
    Eigen::Matrix3d local_from_world;
  };
  PlacedState Place(const SceneState& state) const;
  ShadingPoint ShadeAt(const Eigen::Vector3d& p) const;
  double RadianceAt(const ShadingPoint& point, const Eigen::Vector3d& eye, const SceneState& state, const PlacedState& placed,
                    bool shadows) const;
  // First surface point along a sample-frame ray (direction unit), or nothing if it misses the
  // holder.
  std::optional<Eigen::Vector3d> Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) const;
  // True if the heightfield blocks the segment from surface point `p` towards `light`.
  bool Shadowed(const Eigen::Vector3d& p, const Eigen::Vector3d& light) const;
  // Surface height (mm) at a sample-frame point (0 off the material).
  double HeightAt(double x_mm, double y_mm) const;
  // Geometric normal (sample frame) at a point: the blurred heightmap's, z off the material.
  Eigen::Vector3d GeometricNormalAt(double x_mm, double y_mm) const;

 private:
  struct Surface;  // BRDF parameters and local frame of one map pixel
  std::optional<int> MapPixel(double x_mm, double y_mm) const;

  RigModel rig_;
  Material material_;
  Heightmap heightmap_;                  // from the material's height channel
  std::vector<Eigen::Matrix3d> frames_;  // world_from_local per map pixel (geometric frame)
  std::optional<BeyondLayout> beyond_;   // the material's beyond-GD10 channels, if it has them
  Eigen::Vector3d panchromatic_;
  // FilterWeights of every wheel's every slot, [wheel][slot]: a spectral integral, once per scene
  // rather than once per ray.
  std::vector<std::vector<Eigen::Vector3d>> filter_weights_;

  // Radiance at `p` from one point source at `light` (sample frame) of radiant intensity
  // `intensity` towards p, with `weights` for the albedos.
  double PointSourceRadiance(const ShadingPoint& point, const Eigen::Vector3d& light, double intensity,
                             const Eigen::Vector3d& weights, const Eigen::Vector3d& v_local, bool shadows) const;
};

// The sensor: electrons → DN with noise, 16-bit container holding adc_bits values. `radiance`
// is the whole sensor, or the window `window` of a sensor of `sensor_width` × `sensor_height`
// pixels: vignetting and noise are those of the window's pixels in the whole frame, so a
// window's frame is that frame's crop.
std::vector<uint16_t> CaptureRaw(const Image& radiance, const SensorModel& sensor, const CaptureSettings& settings,
                                 uint64_t noise_seed, bool noise = true);
std::vector<uint16_t> CaptureRaw(const Image& radiance, const SensorModel& sensor, const CaptureSettings& settings,
                                 uint64_t noise_seed, const SensorWindow& window, int sensor_width, int sensor_height);

// The frame of the rig camera named `camera` under `state`: channel "radiance" and channel "raw"
// (CaptureRaw's DN). An unknown camera, or a lit LED the rig lacks, is an error naming it.
Result<Image> RenderCameraFrame(const Scene& scene, const std::string& camera, const SceneState& state,
                                const CaptureSettings& settings, uint64_t noise_seed);

}  // namespace loom::sim
