#include "fitting/io/svbrdf_file.h"

#include <cmath>
#include <sstream>
#include <string>

#include "fitting/io/axf_export.h"

namespace loom::fitting {
namespace {

// What no material has: a parameter that is not a number (but for a pixel NaN in all of them, one
// a fit skipped), a normal of no direction, a negative albedo, a σ that is not positive, an F0
// outside [0, 1]. The first such value, named with its channel and pixel.
Status CheckSvbrdfValues(const Image& maps, const std::string& file) {
  for (int y = 0; y < maps.height(); ++y) {
    for (int x = 0; x < maps.width(); ++x) {
      if (IsSkippedPixel(maps, x, y)) continue;
      const auto at = [&](const std::string& what) {
        return what + " at pixel (" + std::to_string(x) + ", " + std::to_string(y) + ")";
      };
      for (int c = 0; c < kNumWardParams; ++c) {
        if (!std::isfinite(maps.at(c, y, x))) {
          return DataLossError(file, at(std::string(kSvbrdfChannels[c])) + " is " + std::to_string(maps.at(c, y, x)) +
                                         ": a pixel is finite in every parameter, or NaN in all (skipped)");
        }
      }
      const WardParams<double> p = GetParams(maps, x, y);
      if (!(p.n_s.norm() > 0.5)) return DataLossError(file, at("n_s") + " has length " + std::to_string(p.n_s.norm()));
      if ((p.a_d.array() < 0).any() || (p.a_s.array() < 0).any()) return DataLossError(file, at("an albedo") + " is negative");
      if (!(p.sigma_x > 0 && p.sigma_y > 0)) return DataLossError(file, at("sigma") + " is not > 0");
      if (!(p.f0 >= 0 && p.f0 <= 1)) return DataLossError(file, at("F0") + " = " + std::to_string(p.f0) + " is outside [0, 1]");
    }
  }
  return Status::Ok();
}

}  // namespace

Result<SvbrdfFile> ReadSvbrdf(const std::filesystem::path& path) {
  SvbrdfFile file;
  if (path.extension() == ".axf") {
    LOOM_ASSIGN_OR_RETURN(AxfMaps axf, ReadAxf(path));
    file = SvbrdfFile{std::move(axf.maps), axf.pixel_mm};
  } else {
    LOOM_ASSIGN_OR_RETURN(file, ReadSvbrdfExr(path));
  }
  LOOM_RETURN_IF_ERROR(CheckSvbrdfValues(file.maps, path.string()));
  return file;
}

Status CheckOnStackGrid(const SvbrdfFile& maps, int width, int height, double stack_pixel_mm, const std::string& what) {
  if (maps.maps.width() != width || maps.maps.height() != height) {
    return InvalidArgumentError(what, std::to_string(maps.maps.width()) + "x" + std::to_string(maps.maps.height()) +
                                          " px does not match the stack's " + std::to_string(width) + "x" +
                                          std::to_string(height));
  }
  if (maps.pixel_mm > 0 && stack_pixel_mm > 0 && std::abs(maps.pixel_mm - stack_pixel_mm) > 1e-6 * stack_pixel_mm) {
    std::ostringstream message;
    message << "pixels of " << maps.pixel_mm << " mm do not match the stack's " << stack_pixel_mm << " mm";
    return InvalidArgumentError(what, message.str());
  }
  return Status::Ok();
}

}  // namespace loom::fitting
