#pragma once
// The observation stack: the contract between reconstruction (which writes calibrated stacks),
// the simulator's fast path (which writes ideal ones) and fitting (which reads both).
//
// Pixels lie on a regular grid in the top-view reference frame (the sample frame at turntable
// angle 0, x right, y down the image, z up out of the sample; pixel (i, j) is centred at
// ((i + 0.5 − W/2)·pixel_mm, (j + 0.5 − H/2)·pixel_mm)). Channels:
//
// | channel                      | meaning                                        | unit       |
// |------------------------------|------------------------------------------------|------------|
// | pos.X, pos.Y, pos.Z          | surface point (pos.Z: the heightmap)           | mm, sample |
// | normal.X, normal.Y, normal.Z | geometric normal                               | unit       |
// | obs0000, obs0001, ...        | radiance towards observation k's camera        | radiance   |
//
// An observation's radiance is NaN where its camera does not see the point. Shadows are left
// in (the CNN learns from them); a fitter decides them from the heightmap (core/heightmap.h).
//
// Each observation is described in the EXR attribute `loom.observation_table` (JSON): its group
// (colour, monochrome, linear), the camera and its centre in the sample frame (turntable angle
// applied), the colour weights (what the camera records of an RGB albedo: w · a), and its
// light as point emitters, each a position and axis in the sample frame, a radiant intensity
// along the axis and a cosine-power falloff: I(p) = intensity · max(0, axis · (p − e)/|p − e|)^n.
// One LED is one emitter; the linear light is one emitter per strip segment.
//
// Captures from other rigs (loom import) bring two more kinds, as first-class parts of the table:
// an emitter at infinity (a directional light, as light domes and photometric-stereo rigs are
// calibrated: one direction and the irradiance it brings a surface facing it), and an
// orthographic camera (one view direction for every pixel instead of a centre).

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "core/geometry.h"
#include "core/image.h"
#include "core/status.h"

namespace loom {

enum class ObservationGroup { kColour, kMonochrome, kLinearLight };
std::string_view ObservationGroupName(ObservationGroup group);
// The group a name (as ObservationGroupName writes it) stands for; nothing for another name.
std::optional<ObservationGroup> ObservationGroupFromName(std::string_view name);

struct PointEmitter {
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();  // sample frame
  Eigen::Vector3d axis = -Eigen::Vector3d::UnitZ();       // unit, where it emits most
  double intensity = 0;                                   // radiant intensity along the axis
  double falloff_exponent = 1;
  // At infinity: a directional light whose light travels along `axis` everywhere, `intensity`
  // the irradiance it brings a surface facing it; position_mm and falloff_exponent are unused.
  bool at_infinity = false;

  // A directional light arriving from `towards_light` (unit, from the sample to the light).
  static PointEmitter AtInfinity(const Eigen::Vector3d& towards_light, double irradiance);
  // Unit, from `p_in_sample` towards the light.
  Eigen::Vector3d DirectionFrom(const Eigen::Vector3d& p_in_sample) const {
    return at_infinity ? Eigen::Vector3d(-axis) : Eigen::Vector3d((position_mm - p_in_sample).normalized());
  }
  // The irradiance it brings a surface at `p_in_sample` facing it: I(p)/d², or a directional
  // light's own.
  double IrradianceAt(const Eigen::Vector3d& p_in_sample) const;
  // A point on the way to the light beyond every surface of a sample `reach_mm` across: where a
  // shadow test marches towards.
  Eigen::Vector3d ShadowTarget(const Eigen::Vector3d& p_in_sample, double reach_mm) const {
    return at_infinity ? Eigen::Vector3d(p_in_sample - reach_mm * axis) : position_mm;
  }

  double IntensityTowards(const Eigen::Vector3d& p_in_sample) const;
  // The same for a point in the unit direction `from_emitter` (the point minus position_mm,
  // normalised): for a caller that has the direction already. Inline: a fit calls it for each
  // of a pixel's thousands of light samples.
  double IntensityAlong(const Eigen::Vector3d& from_emitter) const {
    const double c = axis.dot(from_emitter);
    return c > 0 ? intensity * CosinePower(c, falloff_exponent) : 0.0;
  }
};

struct StackObservation {
  ObservationGroup group = ObservationGroup::kMonochrome;
  std::string camera;
  Eigen::Vector3d camera_mm = Eigen::Vector3d::Zero();  // camera centre, sample frame
  double turntable_deg = 0;
  Eigen::Vector3d rgb_weights = Eigen::Vector3d::Constant(1.0 / 3);
  std::vector<PointEmitter> emitters;
  std::string description;  // for people: "led 3 at 1000 mA, wheel0 slot 2 (590 nm)"
  // Set: an orthographic camera looking along −view_direction (unit, from the sample towards the
  // camera) at every pixel; camera_mm is unused.
  std::optional<Eigen::Vector3d> view_direction;

  // Unit, from `p_in_sample` towards the camera.
  Eigen::Vector3d ViewFrom(const Eigen::Vector3d& p_in_sample) const {
    return view_direction ? *view_direction : Eigen::Vector3d((camera_mm - p_in_sample).normalized());
  }
};

inline constexpr int kStackGeometryChannels = 6;  // pos.XYZ, normal.XYZ come first
// The pixel sizes a stack may have, in mm: a micrometre to a metre.
inline constexpr double kMinStackPixelMm = 1e-3, kMaxStackPixelMm = 1e3;
// A linear light is one emitter per strip segment (rig files allow up to 1024);
// far more would make a fit take hours with nothing to show for it.
inline constexpr size_t kMaxEmittersPerObservation = 4096;

// A stack made from another rig's photographs (loom import) names its rig so: "import:ps".
inline constexpr std::string_view kImportedRigPrefix = "import:";

struct ObservationStack {
  Image image;  // StackChannelNames(observations.size())
  double pixel_mm = 0;
  std::string rig;     // the rig's name
  std::string source;  // what made it: "sim fast path", "reconstruction"
  std::vector<StackObservation> observations;

  static int ObservationChannel(int observation) { return kStackGeometryChannels + observation; }
  Eigen::Vector3d Position(int x, int y) const;
  Eigen::Vector3d Normal(int x, int y) const;
};

std::vector<std::string> StackChannelNames(size_t observations);

// An empty stack of the right shape: channels named, observations described, the geometric
// normals up (0, 0, 1), everything else 0.
ObservationStack MakeObservationStack(int width, int height, double pixel_mm, std::vector<StackObservation> observations);

// The stack with only the observations `keep` (indices, in that order): their channels and table
// entries, the geometry as it is. For leaving views out of a fit and scoring it on them.
ObservationStack SelectObservations(const ObservationStack& stack, const std::vector<int>& keep);

// The stack on every n-th pixel of each row and column (pixel (i, j) is the stack's (n·i, n·j)):
// every channel and the table as they are, pixel_mm n times the stack's. For what needs a
// stack's observations but not all of its pixels, faster.
ObservationStack EveryNthPixel(const ObservationStack& stack, int n);

// Uncompressed float EXR (radiance noise does not compress), atomically.
Status WriteObservationStack(const std::filesystem::path& path, const ObservationStack& stack);

// Strict: the channels must be exactly StackChannelNames(n) for the n observations of the
// table; the table must parse with every key; the pixel size must lie in [kMinStackPixelMm,
// kMaxStackPixelMm]; positions must be finite and normals unit vectors; an
// observation value may be NaN (unseen) but not ±Inf. Errors name the file and the channel,
// pixel or table entry.
Result<ObservationStack> ReadObservationStack(const std::filesystem::path& path);

// The table alone, as stored in `loom.observation_table`, and back (errors name `source`).
std::string ObservationTableToJson(const std::vector<StackObservation>& observations);
Result<std::vector<StackObservation>> ParseObservationTable(const std::string& json, const std::string& source);

}  // namespace loom
