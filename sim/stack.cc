#include "sim/stack.h"

#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <thread>

#include "core/version.h"

namespace loom::sim {
namespace {

std::vector<std::string> StackChannels(size_t observations) {
  std::vector<std::string> names = {"pos.X", "pos.Y", "pos.Z", "normal.X", "normal.Y", "normal.Z"};
  for (size_t i = 0; i < observations; ++i) {
    std::ostringstream name;
    name << "obs" << std::setw(4) << std::setfill('0') << i;
    names.push_back(name.str());
  }
  return names;
}

std::string FormatPoint(const Eigen::Vector3d& p) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(2) << "[" << (std::abs(p.x()) < 5e-3 ? 0.0 : p.x()) << ", "
      << (std::abs(p.y()) < 5e-3 ? 0.0 : p.y()) << ", " << (std::abs(p.z()) < 5e-3 ? 0.0 : p.z()) << "]";
  return out.str();
}

}  // namespace

std::vector<Observation> DefaultObservations(const RigModel& rig, const std::vector<double>& turntable_deg) {
  std::vector<Observation> observations;
  for (double angle : turntable_deg) {
    for (int camera = 0; camera < static_cast<int>(rig.cameras.size()); ++camera) {
      for (int led = 0; led < static_cast<int>(rig.leds.size()); ++led) {
        observations.push_back({camera, {.leds = {{led, 1000}}, .turntable_deg = angle}});
      }
    }
  }
  for (int wheel = 0; wheel < static_cast<int>(rig.filter_wheels.size()); ++wheel) {
    for (int slot = 0; slot < static_cast<int>(rig.filter_wheels[wheel].filters.size()); ++slot) {
      for (int camera = 0; camera < static_cast<int>(rig.cameras.size()); ++camera) {
        observations.push_back({camera, {.leds = {{rig.filter_wheels[wheel].led, 1000}}, .filter_slots = {{wheel, slot}}}});
      }
    }
  }
  return observations;
}

std::string DescribeObservations(const RigModel& rig, const std::vector<Observation>& observations) {
  std::ostringstream out;
  for (size_t i = 0; i < observations.size(); ++i) {
    const Observation& o = observations[i];
    const Eigen::Vector3d eye = rig.cameras.at(o.camera).CentreInRig();
    out << "obs" << std::setw(4) << std::setfill('0') << i << std::setfill(' ') << ": camera "
        << rig.cameras.at(o.camera).name << " at " << FormatPoint(eye) << " mm, turntable " << o.state.turntable_deg
        << " deg, leds";
    for (const LitLed& led : o.state.leds) {
      out << " " << led.led << "@" << led.current_ma << "mA at " << FormatPoint(rig.leds.at(led.led).position_mm) << " mm";
    }
    for (const auto& [wheel, slot] : o.state.filter_slots) {
      out << ", " << rig.filter_wheels.at(wheel).name << " slot " << slot << " ("
          << rig.filter_wheels.at(wheel).filters.at(slot).center_nm << " nm)";
    }
    out << "\n";
  }
  return out.str();
}

Image RenderStack(const Scene& scene, const std::vector<Observation>& observations, const StackOptions& options) {
  const Material& material = scene.material();
  const double pixel_mm = options.pixel_mm > 0 ? options.pixel_mm : material.pixel_mm;
  const int width = options.width_px > 0 ? options.width_px : material.width();
  const int height = options.height_px > 0 ? options.height_px : material.height();
  Image stack(width, height, StackChannels(observations.size()));
  const RigModel& rig = scene.rig();
  const int threads = options.threads > 0 ? options.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&, t] {
      for (int y = t; y < height; y += threads) {
        for (int x = 0; x < width; ++x) {
          const double px = (x + 0.5 - width / 2.0) * pixel_mm;
          const double py = (y + 0.5 - height / 2.0) * pixel_mm;
          const Eigen::Vector3d p(px, py, scene.HeightAt(px, py));
          const Eigen::Vector3d normal = scene.GeometricNormalAt(px, py);
          for (int i = 0; i < 3; ++i) {
            stack.at(i, y, x) = static_cast<float>(p[i]);
            stack.at(3 + i, y, x) = static_cast<float>(normal[i]);
          }
          for (size_t o = 0; o < observations.size(); ++o) {
            const Observation& observation = observations[o];
            const Rigid3d sample_from_rig = rig.turntable.RigFromSample(observation.state.turntable_deg).inverse();
            const Eigen::Vector3d eye = sample_from_rig * rig.cameras.at(observation.camera).CentreInRig();
            // Seen only if the camera's ray to p meets the surface at p, not before it.
            const std::optional<Eigen::Vector3d> hit = scene.Intersect(eye, (p - eye).normalized());
            const bool visible = hit && (*hit - p).norm() < 0.5 * material.pixel_mm;
            stack.at(6 + static_cast<int>(o), y, x) =
                visible ? static_cast<float>(scene.RadianceAt(p, eye, observation.state, options.shadows))
                        : std::numeric_limits<float>::quiet_NaN();
          }
        }
      }
    });
  }
  for (std::thread& worker : workers) worker.join();
  return stack;
}

Status WriteStack(const std::filesystem::path& path, const Image& stack, const RigModel& rig,
                  const std::vector<Observation>& observations, double pixel_mm) {
  return WriteExr(path, stack,
                  {{"loom.kind", std::string("observation stack (sim fast path)")},
                   {"loom.rig", rig.name},
                   {"loom.pixel_mm", pixel_mm},
                   {"loom.units", std::string("pos mm (sample frame); obs radiance; NaN = not seen")},
                   {"loom.observations", DescribeObservations(rig, observations)},
                   {"loom.version", std::string(VersionWithCommit())}},
                  {.compression = ExrCompression::kNone});
}

}  // namespace loom::sim
