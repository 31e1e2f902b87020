#include "fitting/svbrdf_file.h"

#include "fitting/axf_export.h"

namespace loom::fitting {

Result<SvbrdfFile> ReadSvbrdf(const std::filesystem::path& path) {
  if (path.extension() == ".axf") {
    LOOM_ASSIGN_OR_RETURN(AxfMaps axf, ReadAxf(path));
    return SvbrdfFile{std::move(axf.maps), axf.pixel_mm};
  }
  return ReadSvbrdfExr(path);
}

}  // namespace loom::fitting
