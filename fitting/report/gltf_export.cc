#include "fitting/report/gltf_export.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <sstream>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

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
using internal::MaxSpecularF0;
using internal::SampleFromLocal;
using internal::ToTangentSpace;
using internal::Unit8;
using internal::UnitVectorRgb;

// glTF's dielectric F0 (ior 1.5), which KHR_materials_specular's colour scales.
constexpr double kDielectricF0 = 0.04;

struct Textures {
  cv::Mat base_color, specular_color, metallic_roughness, normal, anisotropy;
  double specular_color_factor = 1;  // over kDielectricF0
};

// Where the shading normal's tilt from the quad's normal is wider than the lobe's narrower
// roughness, KHR_materials_anisotropy's in-plane tangent frame misplaces the highlight.
double TiltOverLobeWidth(const Image& maps, int x, int y, double pixel_mm) {
  const WardParams<double> p = GetParams(maps, x, y);
  const double cos_tilt = std::clamp((SampleFromLocal(maps, x, y, pixel_mm) * p.n_s).z(), 1e-6, 1.0);
  const double tan_tilt = std::sqrt(1 - cos_tilt * cos_tilt) / cos_tilt;
  return tan_tilt / std::max(std::min(p.sigma_x, p.sigma_y), kMinSigma);
}

void FillPixel(const Image& maps, int x, int y, double pixel_mm, double specular_scale, bool anisotropic, Textures* t) {
  const WardParams<double> p = GetParams(maps, x, y);
  t->base_color.at<cv::Vec3b>(y, x) = {ToSrgb8(p.a_d.z()), ToSrgb8(p.a_d.y()), ToSrgb8(p.a_d.x())};
  const Eigen::Vector3d f0 = p.a_s * p.f0 / specular_scale;
  t->specular_color.at<cv::Vec3b>(y, x) = {ToSrgb8(f0.z()), ToSrgb8(f0.y()), ToSrgb8(f0.x())};
  const GltfRoughness roughness = GltfRoughnessOf(p.sigma_x, p.sigma_y);
  const double isotropic_roughness = std::sqrt(std::sqrt(GgxAlphaOfWardSigma(p.sigma_x) * GgxAlphaOfWardSigma(p.sigma_y)));
  t->metallic_roughness.at<cv::Vec3b>(y, x) = {0, Unit8(anisotropic ? roughness.roughness : isotropic_roughness),
                                               0};  // B metallic, G roughness
  const Eigen::Matrix3d sample_from_local = SampleFromLocal(maps, x, y, pixel_mm);
  t->normal.at<cv::Vec3b>(y, x) = UnitVectorRgb(ToTangentSpace(sample_from_local * p.n_s));
  if (!anisotropic) return;
  const AnisotropyFrame<double> frame = MakeAnisotropyFrame(p.n_s, p.alpha);
  const Eigen::Vector3d axis = ToTangentSpace(sample_from_local * (roughness.along_b ? frame.b : frame.t));
  const Eigen::Vector2d direction = Eigen::Vector2d(axis.x(), axis.y()).normalized();
  t->anisotropy.at<cv::Vec3b>(y, x) = {Unit8(roughness.anisotropy_strength), Unit8((direction.y() + 1) / 2),
                                       Unit8((direction.x() + 1) / 2)};
}

// A texture's size: the maps' own, padded to powers of two, because WebGL 1 renderers cannot
// mipmap other sizes (Khronos' validator flags them). Padding keeps every texel exact where
// resampling would not; the quad's texture coordinates cover only the maps' part.
cv::Size TextureSize(const Image& maps) {
  return {static_cast<int>(std::bit_ceil(static_cast<unsigned>(maps.width()))),
          static_cast<int>(std::bit_ceil(static_cast<unsigned>(maps.height())))};
}

// The maps' texels repeated outwards into the padding, so that filtering at the quad's edge
// and coarser mipmap levels see the edge's value rather than black.
void PadToTextureSize(const cv::Size& size, cv::Mat* texture) {
  cv::copyMakeBorder(*texture, *texture, 0, size.height - texture->rows, 0, size.width - texture->cols, cv::BORDER_REPLICATE);
}

Textures MakeTextures(const Image& maps, double pixel_mm, bool anisotropic) {
  const int w = maps.width(), h = maps.height();
  Textures t{cv::Mat(h, w, CV_8UC3), cv::Mat(h, w, CV_8UC3), cv::Mat(h, w, CV_8UC3), cv::Mat(h, w, CV_8UC3),
             anisotropic ? cv::Mat(h, w, CV_8UC3) : cv::Mat()};
  const double max_f0 = MaxSpecularF0(maps);
  t.specular_color_factor = max_f0 > 0 ? max_f0 / kDielectricF0 : 1;
  const double specular_scale = max_f0 > 0 ? max_f0 : 1;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) FillPixel(maps, x, y, pixel_mm, specular_scale, anisotropic, &t);
  }
  for (cv::Mat* texture : {&t.base_color, &t.specular_color, &t.metallic_roughness, &t.normal, &t.anisotropy}) {
    if (!texture->empty()) PadToTextureSize(TextureSize(maps), texture);
  }
  return t;
}

// The quad: 4 vertices (position, normal, tangent, uv) and 2 triangles, in glTF's frame
// (+y up: the sample's z), metres. Pixel rows run along the sample's +y, which is glTF's −z.
// `u_max`, `v_max`: the maps' part of the padded textures.
std::vector<uint8_t> QuadBuffer(double half_width_m, double half_height_m, float u_max, float v_max) {
  const float hx = static_cast<float>(half_width_m), hy = static_cast<float>(half_height_m);
  const float positions[] = {-hx, 0, hy, hx, 0, hy, hx, 0, -hy, -hx, 0, -hy};  // sample y = −H/2 first
  const float normals[] = {0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0};
  const float tangents[] = {1, 0, 0, -1, 1, 0, 0, -1, 1, 0, 0, -1, 1, 0, 0, -1};
  const float uvs[] = {0, 0, u_max, 0, u_max, v_max, 0, v_max};
  const uint16_t indices[] = {0, 1, 2, 0, 2, 3};  // counter-clockwise seen from above (+y)
  std::vector<uint8_t> buffer;
  for (const auto& [data, bytes] : std::initializer_list<std::pair<const void*, size_t>>{{positions, sizeof positions},
                                                                                         {normals, sizeof normals},
                                                                                         {tangents, sizeof tangents},
                                                                                         {uvs, sizeof uvs},
                                                                                         {indices, sizeof indices}}) {
    const size_t at = buffer.size();
    buffer.resize(at + bytes);
    std::memcpy(buffer.data() + at, data, bytes);
  }
  return buffer;
}

nlohmann::json Accessor(int view, int component_type, const char* type) {
  return {{"bufferView", view}, {"componentType", component_type}, {"count", view == 4 ? 6 : 4}, {"type", type}};
}

nlohmann::json GltfDocument(double half_width_m, double half_height_m, double specular_color_factor, size_t buffer_bytes,
                            const GltfAnisotropyChoice& anisotropy) {
  constexpr int kFloat = 5126, kUnsignedShort = 5123, kArrayBuffer = 34962, kElementArrayBuffer = 34963;
  nlohmann::json views = nlohmann::json::array();
  const size_t sizes[] = {48, 48, 64, 32, 12};
  size_t offset = 0;
  for (int v = 0; v < 5; ++v) {
    views.push_back({{"buffer", 0},
                     {"byteOffset", offset},
                     {"byteLength", sizes[v]},
                     {"target", v == 4 ? kElementArrayBuffer : kArrayBuffer}});
    offset += sizes[v];
  }
  nlohmann::json position = Accessor(0, kFloat, "VEC3");
  position["min"] = {-half_width_m, 0.0, -half_height_m};
  position["max"] = {half_width_m, 0.0, half_height_m};
  nlohmann::json textures = nlohmann::json::array(), images = nlohmann::json::array();
  for (const char* name : {"base_color", "metallic_roughness", "normal", "specular_color", "anisotropy"}) {
    if (std::string_view(name) == "anisotropy" && !anisotropy.anisotropic) continue;
    textures.push_back({{"source", images.size()}, {"sampler", 0}});
    images.push_back({{"uri", std::string(name) + ".png"}});
  }
  const double f = specular_color_factor;
  nlohmann::json extensions = {
      {"KHR_materials_specular",
       {{"specularFactor", 1.0}, {"specularColorFactor", {f, f, f}}, {"specularColorTexture", {{"index", 3}}}}}};
  nlohmann::json extensions_used = {"KHR_materials_specular"};
  if (anisotropy.anisotropic) {
    extensions["KHR_materials_anisotropy"] = {
        {"anisotropyStrength", 1.0}, {"anisotropyRotation", 0.0}, {"anisotropyTexture", {{"index", 4}}}};
    extensions_used = {"KHR_materials_anisotropy", "KHR_materials_specular"};
  }
  return {
      {"asset", {{"version", "2.0"}, {"generator", "loom " + std::string(VersionWithCommit())}}},
      {"extensionsUsed", extensions_used},
      {"scene", 0},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes", {{{"mesh", 0}, {"name", "sample"}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}, {"TANGENT", 2}, {"TEXCOORD_0", 3}}},
            {"indices", 4},
            {"material", 0}}}}}}},
      {"materials",
       {{{"name", "loom SVBRDF (GD10-Ward approximated: see loom's fitting/report/gltf_export.h)"},
         {"pbrMetallicRoughness",
          {{"baseColorTexture", {{"index", 0}}},
           {"metallicRoughnessTexture", {{"index", 1}}},
           {"metallicFactor", 0.0},
           {"roughnessFactor", 1.0}}},
         {"normalTexture", {{"index", 2}}},
         {"extensions", extensions},
         {"extras", {{"loom_anisotropy", anisotropy.reason}}}}}},
      {"textures", textures},
      {"images", images},
      {"samplers", {{{"magFilter", 9729}, {"minFilter", 9987}, {"wrapS", 33071}, {"wrapT", 33071}}}},
      {"buffers", {{{"uri", "material.bin"}, {"byteLength", buffer_bytes}}}},
      {"bufferViews", views},
      {"accessors",
       {position, Accessor(1, kFloat, "VEC3"), Accessor(2, kFloat, "VEC4"), Accessor(3, kFloat, "VEC2"),
        Accessor(4, kUnsignedShort, "SCALAR")}},
  };
}

}  // namespace

GltfRoughness GltfRoughnessOf(double sigma_x, double sigma_y) {
  const double alpha_t = GgxAlphaOfWardSigma(std::max(sigma_x, sigma_y));
  const double alpha_b = GgxAlphaOfWardSigma(std::min(sigma_x, sigma_y));
  const double strength = alpha_b < 1 ? std::sqrt((alpha_t - alpha_b) / (1 - alpha_b)) : 0;
  return {std::sqrt(alpha_b), strength, sigma_y > sigma_x};
}

GltfAnisotropyChoice ChooseGltfAnisotropy(const Image& maps, double pixel_mm, GltfAnisotropy mode) {
  if (mode == GltfAnisotropy::kOn) return {true, "anisotropic, as asked"};
  if (mode == GltfAnisotropy::kOff) return {false, "isotropic, as asked"};
  std::vector<double> ratios;
  for (int y = 0; y < maps.height(); ++y) {
    for (int x = 0; x < maps.width(); ++x) ratios.push_back(TiltOverLobeWidth(maps, x, y, pixel_mm));
  }
  const auto median = ratios.begin() + static_cast<std::ptrdiff_t>(ratios.size() / 2);
  std::nth_element(ratios.begin(), median, ratios.end());
  std::ostringstream reason;
  reason << std::setprecision(2) << "the shading normals' tilt is " << *median
         << "x the narrower lobe width (median of tan(tilt) / min(sigma))";
  if (*median <= 1) return {true, "anisotropic: " + reason.str() + ", at most 1"};
  return {false,
          "isotropic: " + reason.str() + ", above 1: KHR_materials_anisotropy's in-plane tangents would misplace the highlights"};
}

Result<GltfAnisotropyChoice> WriteGltf(const Image& maps, double pixel_mm, const std::filesystem::path& dir,
                                       GltfAnisotropy anisotropy) {
  if (!HasSvbrdfLayout(maps)) return InvalidArgumentError("glTF export", "the maps are not in the SVBRDF layout");
  if (!(pixel_mm > 0)) return InvalidArgumentError("glTF export", "needs the maps' pixel size (loom.pixel_mm)");
  LOOM_ASSIGN_OR_RETURN(OutputDirectory out, OutputDirectory::Create(dir, "glTF directory"));
  const GltfAnisotropyChoice choice = ChooseGltfAnisotropy(maps, pixel_mm, anisotropy);
  const Textures t = MakeTextures(maps, pixel_mm, choice.anisotropic);
  for (const auto& [name, image] : {std::pair{"base_color", &t.base_color},
                                    {"specular_color", &t.specular_color},
                                    {"metallic_roughness", &t.metallic_roughness},
                                    {"normal", &t.normal},
                                    {"anisotropy", &t.anisotropy}}) {
    if (image->empty()) continue;
    LOOM_RETURN_IF_ERROR(internal::WritePng(out.partial() / (std::string(name) + ".png"), *image));
  }
  const double half_width_m = maps.width() * pixel_mm / 2000, half_height_m = maps.height() * pixel_mm / 2000;
  const cv::Size texture_size = TextureSize(maps);
  const std::vector<uint8_t> buffer =
      QuadBuffer(half_width_m, half_height_m, static_cast<float>(maps.width()) / texture_size.width,
                 static_cast<float>(maps.height()) / texture_size.height);
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(out.partial() / "material.bin", std::string(buffer.begin(), buffer.end())));
  const nlohmann::json document = GltfDocument(half_width_m, half_height_m, t.specular_color_factor, buffer.size(), choice);
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(out.partial() / "material.gltf", document.dump(2) + "\n"));
  LOOM_RETURN_IF_ERROR(out.Commit());
  return choice;
}

}  // namespace loom::fitting
