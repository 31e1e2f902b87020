#include "fitting/report/mtlx_export.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/core.hpp>

#include "core/file_io.h"
#include "core/output_directory.h"
#include "core/version.h"
#include "fitting/io/internal/geometric_frame.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/report/export.h"
#include "fitting/report/internal/png.h"
#include "fitting/report/internal/texture_frame.h"

namespace loom::fitting {
namespace {

using internal::GgxAlphaOfWardSigma;
using internal::Unit8;

// Standard Surface clamps its anisotropy there (mx_roughness_anisotropy).
constexpr double kMaxAnisotropy = 0.98;
// A dielectric reflecting more than this at normal incidence needs an IOR beyond any material's.
constexpr double kMaxDielectricF0 = 0.9;

struct Textures {
  cv::Mat base_color, specular_color, roughness, anisotropy, rotation, normal;
};

// The wider axis' angle from the tangent (T, along the image's columns) as a fraction of a turn
// in [0, 0.5), turning clockwise about the quad's normal (from T towards T × N, up the image),
// because that is how MaterialX's rotate3d turns the tangent by specular_rotation: its GLSL, ESSL
// and OSL build the rotation matrix transposed (MaterialX issue #2083), so documents render as
// written in the library's own shaders. Cycles, which turns right-handedly, reads the opposite
// (blender/render_check.py).
double RotationOfWiderAxis(const Image& maps, int x, int y, double pixel_mm, const WardParams<double>& p) {
  const AnisotropyFrame<double> frame = MakeAnisotropyFrame(p.n_s, p.alpha);
  const Eigen::Vector3d wider = p.sigma_y > p.sigma_x ? frame.b : frame.t;
  const Eigen::Vector3d axis = internal::SampleFromLocal(maps, x, y, pixel_mm) * wider;
  const double turns = -std::atan2(axis.y(), axis.x()) / (2 * M_PI);
  return turns - std::floor(turns * 2) / 2;  // modulo half a turn
}

void FillPixel(const Image& maps, int x, int y, double pixel_mm, double f0_max, Textures* t) {
  const WardParams<double> p = GetParams(maps, x, y);
  t->base_color.at<cv::Vec3b>(y, x) = {ToSrgb8(p.a_d.z()), ToSrgb8(p.a_d.y()), ToSrgb8(p.a_d.x())};
  const Eigen::Vector3d tint = p.a_s * p.f0 / f0_max;
  t->specular_color.at<cv::Vec3b>(y, x) = {ToSrgb8(tint.z()), ToSrgb8(tint.y()), ToSrgb8(tint.x())};
  const StandardSurfaceRoughness lobe = StandardSurfaceRoughnessOf(p.sigma_x, p.sigma_y);
  t->roughness.at<uint8_t>(y, x) = Unit8(lobe.roughness);
  t->anisotropy.at<uint8_t>(y, x) = Unit8(lobe.anisotropy);
  t->rotation.at<uint8_t>(y, x) = Unit8(RotationOfWiderAxis(maps, x, y, pixel_mm, p));
  const Eigen::Vector3d normal = internal::ToTangentSpace(internal::SampleFromLocal(maps, x, y, pixel_mm) * p.n_s);
  t->normal.at<cv::Vec3b>(y, x) = internal::UnitVectorRgb(normal);
}

Textures MakeTextures(const Image& maps, double pixel_mm, double f0_max) {
  const int w = maps.width(), h = maps.height();
  Textures t{cv::Mat(h, w, CV_8UC3), cv::Mat(h, w, CV_8UC3), cv::Mat(h, w, CV_8UC1),
             cv::Mat(h, w, CV_8UC1), cv::Mat(h, w, CV_8UC1), cv::Mat(h, w, CV_8UC3)};
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) FillPixel(maps, x, y, pixel_mm, f0_max, &t);
  }
  return t;
}

// The IOR whose dielectric reflects `f0` at normal incidence: ((n − 1) / (n + 1))² = f0.
double IorOfF0(double f0) {
  const double root = std::sqrt(std::clamp(f0, 1e-4, kMaxDielectricF0));
  return (1 + root) / (1 - root);
}

void ImageNode(std::ostream& out, const char* name, const char* type, const char* colorspace) {
  out << "  <image name=\"" << name << "\" type=\"" << type << "\">\n"
      << "    <input name=\"file\" type=\"filename\" value=\"" << name << ".png\"";
  if (colorspace) out << " colorspace=\"" << colorspace << "\"";
  out << " />\n  </image>\n";
}

void ConnectedInput(std::ostream& out, const char* name, const char* type, const char* node) {
  out << "    <input name=\"" << name << "\" type=\"" << type << "\" nodename=\"" << node << "\" />\n";
}

void ValueInput(std::ostream& out, const char* name, double value) {
  out << "    <input name=\"" << name << "\" type=\"float\" value=\"" << value << "\" />\n";
}

std::string Document(const Image& maps, double pixel_mm, double ior) {
  std::ostringstream out;
  out.precision(6);
  out << "<?xml version=\"1.0\"?>\n"
      << "<!-- Written by loom " << VersionWithCommit()
      << ": GD10-Ward SVBRDF maps as Autodesk Standard Surface (fitting/report/mtlx_export.h says how). -->\n"
      << "<materialx version=\"1.39\" colorspace=\"lin_rec709\">\n";
  ImageNode(out, "base_color", "color3", "srgb_texture");
  ImageNode(out, "specular_color", "color3", "srgb_texture");
  ImageNode(out, "roughness", "float", nullptr);
  ImageNode(out, "anisotropy", "float", nullptr);
  ImageNode(out, "rotation", "float", nullptr);
  ImageNode(out, "normal", "vector3", nullptr);
  out << "  <normalmap name=\"shading_normal\" type=\"vector3\">\n";
  ConnectedInput(out, "in", "vector3", "normal");
  out << "  </normalmap>\n"
      << "  <standard_surface name=\"loom_surface\" type=\"surfaceshader\">\n";
  ValueInput(out, "base", 1);
  ConnectedInput(out, "base_color", "color3", "base_color");
  ValueInput(out, "diffuse_roughness", 0);
  ValueInput(out, "metalness", 0);
  ValueInput(out, "specular", 1);
  ConnectedInput(out, "specular_color", "color3", "specular_color");
  ValueInput(out, "specular_IOR", ior);
  ConnectedInput(out, "specular_roughness", "float", "roughness");
  ConnectedInput(out, "specular_anisotropy", "float", "anisotropy");
  ConnectedInput(out, "specular_rotation", "float", "rotation");
  ConnectedInput(out, "normal", "vector3", "shading_normal");
  out << "  </standard_surface>\n"
      << "  <surfacematerial name=\"loom_material\" type=\"material\" doc=\"A " << maps.width() * pixel_mm << " x "
      << maps.height() * pixel_mm << " mm sample, " << maps.width() << " x " << maps.height()
      << " texels: u along the image's columns, v up its rows\">\n";
  ConnectedInput(out, "surfaceshader", "surfaceshader", "loom_surface");
  out << "  </surfacematerial>\n"
      << "</materialx>\n";
  return out.str();
}

}  // namespace

StandardSurfaceRoughness StandardSurfaceRoughnessOf(double sigma_x, double sigma_y) {
  const double alpha_t = GgxAlphaOfWardSigma(std::max(sigma_x, sigma_y));
  const double alpha_b = GgxAlphaOfWardSigma(std::min(sigma_x, sigma_y));
  return {std::sqrt(std::sqrt(alpha_t * alpha_b)), std::min(1 - alpha_b / alpha_t, kMaxAnisotropy)};
}

Status WriteMaterialX(const Image& maps, double pixel_mm, const std::filesystem::path& dir) {
  if (!HasSvbrdfLayout(maps)) return InvalidArgumentError("MaterialX export", "the maps are not in the SVBRDF layout");
  if (!(pixel_mm > 0)) return InvalidArgumentError("MaterialX export", "needs the maps' pixel size (loom.pixel_mm)");
  LOOM_ASSIGN_OR_RETURN(OutputDirectory out, OutputDirectory::Create(dir, "--mtlx"));
  const double f0_max = std::clamp(internal::MaxSpecularF0(maps), 1e-4, kMaxDielectricF0);
  const Textures t = MakeTextures(maps, pixel_mm, f0_max);
  for (const auto& [name, image] : {std::pair{"base_color", &t.base_color},
                                    {"specular_color", &t.specular_color},
                                    {"roughness", &t.roughness},
                                    {"anisotropy", &t.anisotropy},
                                    {"rotation", &t.rotation},
                                    {"normal", &t.normal}}) {
    LOOM_RETURN_IF_ERROR(internal::WritePng(out.partial() / (std::string(name) + ".png"), *image));
  }
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(out.partial() / "material.mtlx", Document(maps, pixel_mm, IorOfF0(f0_max))));
  return out.Commit();
}

}  // namespace loom::fitting
