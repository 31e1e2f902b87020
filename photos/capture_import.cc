#include "photos/capture_import.h"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/duration.h"
#include "core/exr_io.h"
#include "core/file_io.h"
#include "core/parallel.h"
#include "core/srgb.h"

namespace loom::photos {
namespace {

namespace fs = std::filesystem;

// ---- text files ----

// The numbers of each non-empty line (separated by spaces, tabs or commas).
Result<std::vector<std::vector<double>>> ReadNumberRows(const fs::path& path) {
  if (!fs::exists(path)) return NotFoundError(path.string(), "missing");
  LOOM_ASSIGN_OR_RETURN(const std::string text, ReadFile(path));
  std::vector<std::vector<double>> rows;
  std::istringstream lines(text);
  std::string line;
  for (int number = 1; std::getline(lines, line); ++number) {
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    std::vector<double> row;
    std::string field;
    while (fields >> field) {
      double v = 0;
      const auto [end, error] = std::from_chars(field.data(), field.data() + field.size(), v);
      if (error != std::errc() || end != field.data() + field.size() || !std::isfinite(v)) {
        return InvalidArgumentError(path.string() + ":" + std::to_string(number), "'" + field + "' is not a number");
      }
      row.push_back(v);
    }
    if (!row.empty()) rows.push_back(std::move(row));
  }
  return rows;
}

// Rows of exactly `width` numbers, `count` of them (count < 0: any).
Result<std::vector<std::vector<double>>> ReadTable(const fs::path& path, size_t width, int count, const std::string& what) {
  LOOM_ASSIGN_OR_RETURN(std::vector<std::vector<double>> rows, ReadNumberRows(path));
  for (size_t r = 0; r < rows.size(); ++r) {
    if (rows[r].size() != width) {
      return InvalidArgumentError(
          path.string() + ":" + std::to_string(r + 1),
          "expected " + what + " (" + std::to_string(width) + " numbers), got " + std::to_string(rows[r].size()));
    }
  }
  if (count >= 0 && rows.size() != static_cast<size_t>(count)) {
    return InvalidArgumentError(path.string(),
                                std::to_string(rows.size()) + " lines of " + what + " for " + std::to_string(count) + " images");
  }
  return rows;
}

Result<std::vector<std::string>> ReadLines(const fs::path& path) {
  if (!fs::exists(path)) return NotFoundError(path.string(), "missing");
  LOOM_ASSIGN_OR_RETURN(const std::string text, ReadFile(path));
  std::vector<std::string> lines;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
    if (!line.empty()) lines.push_back(line);
  }
  return lines;
}

// ---- images ----

struct Photo {
  cv::Mat values;  // CV_32FC1 or CV_32FC3 (R, G, B), stored values scaled to [0, 1]; NaN = clipped
  int bits = 8;    // of the stored values (32: floating point)
  int64_t clipped = 0;
};

// A PNG's bit depth from its header (0 when `path` is no PNG).
// What an image file's header declares, read before OpenCV decodes it: OpenCV refuses (and
// prints its own assertion) past 2^30 px, and decoding what fits could still exhaust memory.
struct DeclaredImage {
  int bits = 0;  // PNG only; 0 when unknown
  uint64_t width = 0, height = 0;
};

uint64_t BigEndian(const unsigned char* bytes, int count) {
  uint64_t value = 0;
  for (int i = 0; i < count; ++i) value = value << 8 | bytes[i];
  return value;
}

// PNG: the IHDR chunk; JPEG: the first start-of-frame marker. Nothing declared for other files.
DeclaredImage ReadDeclaredImage(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<unsigned char> head(1 << 16);
  in.read(reinterpret_cast<char*>(head.data()), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<size_t>(in.gcount()));
  static constexpr unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (head.size() >= 26 && std::equal(kPng, kPng + 8, head.begin())) {
    return {head[24], BigEndian(&head[16], 4), BigEndian(&head[20], 4)};
  }
  if (head.size() < 4 || head[0] != 0xFF || head[1] != 0xD8) return {};
  for (size_t at = 2; at + 9 < head.size() && head[at] == 0xFF;) {
    const unsigned char marker = head[at + 1];
    const bool start_of_frame = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (start_of_frame) return {0, BigEndian(&head[at + 7], 2), BigEndian(&head[at + 5], 2)};
    at += 2 + BigEndian(&head[at + 2], 2);
  }
  return {};
}

// The most pixels one photograph may have: 2^28 (268 MP, 3 GB as float RGB).
constexpr uint64_t kMaxPhotoPixels = uint64_t{1} << 28;

Status CheckDeclaredImage(const fs::path& path, const DeclaredImage& declared) {
  if (declared.bits != 0 && declared.bits != 8 && declared.bits != 16) {
    return InvalidArgumentError(path.string(), "a " + std::to_string(declared.bits) + "-bit PNG: expected 8- or 16-bit images");
  }
  if (declared.width * declared.height > kMaxPhotoPixels) {
    return InvalidArgumentError(path.string(), "declares " + std::to_string(declared.width) + " × " +
                                                   std::to_string(declared.height) + " px, more than the " +
                                                   std::to_string(kMaxPhotoPixels >> 20) + " M px loom imports");
  }
  return Status::Ok();
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

// An EXR image's first complete set among `sets` of channel names (R, G, B or Y for a photograph;
// X, Y, Z first for a normal map).
Result<Photo> ReadExrPhoto(const fs::path& path, const std::vector<std::vector<std::string>>& sets = {{"R", "G", "B"}, {"Y"}}) {
  LOOM_ASSIGN_OR_RETURN(const ExrImage exr, ReadExr(path));
  const Image& image = exr.image;
  std::vector<int> channels;
  for (const std::vector<std::string>& set : sets) {
    channels.clear();
    for (const std::string& name : set) {
      if (const std::optional<int> c = image.FindChannel(name)) channels.push_back(*c);
    }
    if (channels.size() == set.size()) break;
    channels.clear();
  }
  if (channels.empty()) {
    std::string expected;
    for (const auto& set : sets) {
      expected += expected.empty() ? "" : " or ";
      for (const std::string& name : set) expected += name;
    }
    return InvalidArgumentError(path.string(), "an EXR image needs channels " + expected);
  }
  Photo photo;
  photo.bits = 32;
  photo.values = cv::Mat(image.height(), image.width(), channels.size() == 3 ? CV_32FC3 : CV_32FC1);
  for (int y = 0; y < image.height(); ++y) {
    float* row = photo.values.ptr<float>(y);
    for (int x = 0; x < image.width(); ++x) {
      for (size_t c = 0; c < channels.size(); ++c) row[x * channels.size() + c] = image.at(channels[c], y, x);
    }
  }
  return photo;
}

// 8- or 16-bit PNG, JPEG (8-bit) or EXR; colour as R, G, B; values at the top of the range NaN
// (clipped) when `mark_clipped`.
Result<Photo> ReadPhoto(const fs::path& path, bool mark_clipped = true) {
  if (!fs::exists(path)) return NotFoundError(path.string(), "missing");
  const std::string extension = Lower(path.extension().string());
  if (extension == ".exr") return ReadExrPhoto(path);
  LOOM_RETURN_IF_ERROR(CheckDeclaredImage(path, ReadDeclaredImage(path)));
  const cv::Mat stored = cv::imread(path.string(), cv::IMREAD_UNCHANGED | cv::IMREAD_ANYDEPTH);
  if (stored.empty()) return InvalidArgumentError(path.string(), "not an image OpenCV reads (PNG, JPEG or EXR expected)");
  if (stored.depth() != CV_8U && stored.depth() != CV_16U) {
    return InvalidArgumentError(path.string(), "expected 8- or 16-bit values");
  }
  cv::Mat colour;
  switch (stored.channels()) {
    case 1:
      colour = stored;
      break;
    case 3:
      cv::cvtColor(stored, colour, cv::COLOR_BGR2RGB);
      break;
    case 4:
      cv::cvtColor(stored, colour, cv::COLOR_BGRA2RGB);
      break;
    default:
      return InvalidArgumentError(path.string(), std::to_string(stored.channels()) + " channels: expected grey or RGB");
  }
  Photo photo;
  photo.bits = stored.depth() == CV_8U ? 8 : 16;
  const double top = photo.bits == 8 ? 255.0 : 65535.0;
  colour.convertTo(photo.values, colour.channels() == 3 ? CV_32FC3 : CV_32FC1, 1.0 / top);
  float* const end = photo.values.ptr<float>() + photo.values.total() * photo.values.channels();
  for (float* v = photo.values.ptr<float>(); mark_clipped && v != end; ++v) {
    if (*v >= 1.0f) *v = NAN, ++photo.clipped;
  }
  return photo;
}

double Decode(double v, const Encoding& encoding) {
  switch (encoding.kind) {
    case Encoding::Kind::kLinear:
      return v;
    case Encoding::Kind::kSrgb:
      return SrgbDecode(v);
    case Encoding::Kind::kGamma:
      return std::pow(std::max(0.0, v), encoding.gamma);
  }
  return v;
}

Encoding DefaultEncoding(Layout layout, int bits) {
  if (bits != 8) return {};
  if (layout == Layout::kFlash) return {Encoding::Kind::kGamma, 2.2};
  return {Encoding::Kind::kSrgb, 1};
}

// ---- the capture, before it is a stack ----

// One image with its light(s) and camera, in the stack frame (y down the image).
struct Shot {
  fs::path image;
  Eigen::Vector3d intensity = Eigen::Vector3d::Ones();  // per channel: divided out (ps) or the emitters' (flash)
  std::optional<Eigen::Vector3d> towards_light;         // directional
  Eigen::Vector3d light_mm = Eigen::Vector3d::Zero();   // point
  Eigen::Vector3d camera_mm = Eigen::Vector3d::Zero();  // point camera, unless orthographic
  bool orthographic = false;
};

struct Capture {
  std::vector<Shot> shots;
  std::optional<fs::path> mask;
  std::optional<double> width_mm;  // the whole image's (flash)
};

Eigen::Vector3d YUpToYDown(const Eigen::Vector3d& v) { return {v.x(), -v.y(), v.z()}; }

Result<Eigen::Vector3d> UnitDirection(const std::vector<double>& row, const fs::path& file, size_t line) {
  const Eigen::Vector3d d(row[0], row[1], row[2]);
  if (!(d.norm() > 0.5 && d.norm() < 1.5)) {
    return InvalidArgumentError(file.string() + ":" + std::to_string(line), "a light direction must be a unit vector");
  }
  if (d.z() <= 0) {
    return InvalidArgumentError(file.string() + ":" + std::to_string(line),
                                "a light direction must point towards the camera (z > 0)");
  }
  return d.normalized();
}

Result<Capture> ReadPhotometricStereo(const fs::path& dir) {
  LOOM_ASSIGN_OR_RETURN(const std::vector<std::string> names, ReadLines(dir / "filenames.txt"));
  if (names.empty()) return InvalidArgumentError((dir / "filenames.txt").string(), "lists no image");
  const int count = static_cast<int>(names.size());
  LOOM_ASSIGN_OR_RETURN(const auto directions, ReadTable(dir / "light_directions.txt", 3, count, "a light direction x y z"));
  std::vector<std::vector<double>> intensities(count, {1.0, 1.0, 1.0});
  if (fs::exists(dir / "light_intensities.txt")) {
    LOOM_ASSIGN_OR_RETURN(intensities, ReadTable(dir / "light_intensities.txt", 3, count, "a light intensity r g b"));
  }
  Capture capture;
  for (int k = 0; k < count; ++k) {
    Shot shot;
    shot.image = dir / names[k];
    LOOM_ASSIGN_OR_RETURN(const Eigen::Vector3d towards, UnitDirection(directions[k], dir / "light_directions.txt", k + 1));
    shot.towards_light = YUpToYDown(towards);
    shot.intensity = {intensities[k][0], intensities[k][1], intensities[k][2]};
    if (!(shot.intensity.minCoeff() > 0)) {
      return InvalidArgumentError((dir / "light_intensities.txt").string() + ":" + std::to_string(k + 1),
                                  "intensities must be > 0");
    }
    shot.orthographic = true;
    capture.shots.push_back(shot);
  }
  if (fs::exists(dir / "mask.png")) capture.mask = dir / "mask.png";
  return capture;
}

std::vector<fs::path> FilesEndingIn(const fs::path& dir, const std::string& extension) {
  std::vector<fs::path> files;
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
    if (e.is_regular_file() && Lower(e.path().extension().string()) == extension) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// An .lp line's image name, which may hold spaces, and its direction, the last three fields.
struct LpLine {
  std::string image;
  std::vector<double> direction;
};
std::optional<LpLine> ParseLpLine(const std::string& line) {
  std::vector<std::pair<size_t, size_t>> fields;  // [begin, end) of each whitespace-separated field
  for (size_t at = 0; at < line.size();) {
    const size_t begin = line.find_first_not_of(" \t", at);
    if (begin == std::string::npos) break;
    const size_t end = std::min(line.find_first_of(" \t", begin), line.size());
    fields.emplace_back(begin, end);
    at = end;
  }
  if (fields.size() < 4) return std::nullopt;
  LpLine parsed;
  for (size_t f = fields.size() - 3; f < fields.size(); ++f) {
    double value = 0;
    const auto [end, error] = std::from_chars(line.data() + fields[f].first, line.data() + fields[f].second, value);
    if (error != std::errc() || end != line.data() + fields[f].second) return std::nullopt;
    parsed.direction.push_back(value);
  }
  parsed.image = line.substr(0, fields[fields.size() - 4].second);
  return parsed;
}

// Where an .lp line's image is: its name as written, relative to the .lp file's folder, or its
// file name there or in a jpeg-exports/ folder beside it or beside that folder, where RTIBuilder
// puts the images of a project whose .lp (in assembly-files/) names them by absolute Windows paths.
fs::path LpImage(const fs::path& dir, const std::string& name) {
  const std::string file_name = name.substr(name.find_last_of("/\\") + 1);
  for (const fs::path& candidate :
       {dir / name, dir / file_name, dir / "jpeg-exports" / file_name, dir.parent_path() / "jpeg-exports" / file_name}) {
    if (fs::exists(candidate)) return candidate;
  }
  return dir / file_name;  // reported missing, by this name, where the images are read
}

Result<Capture> ReadLightPositions(const fs::path& dir) {
  const std::vector<fs::path> lp = FilesEndingIn(dir, ".lp");
  if (lp.size() != 1) return InvalidArgumentError(dir.string(), "expected one .lp file, found " + std::to_string(lp.size()));
  LOOM_ASSIGN_OR_RETURN(const std::vector<std::string> lines, ReadLines(lp[0]));
  int count = 0;
  if (lines.empty() || std::from_chars(lines[0].data(), lines[0].data() + lines[0].size(), count).ec != std::errc() ||
      count < 1) {
    return InvalidArgumentError(lp[0].string() + ":1", "expected the image count");
  }
  if (static_cast<int>(lines.size()) - 1 != count) {
    return InvalidArgumentError(lp[0].string(),
                                "says " + std::to_string(count) + " images but lists " + std::to_string(lines.size() - 1));
  }
  Capture capture;
  for (int k = 0; k < count; ++k) {
    const std::optional<LpLine> line = ParseLpLine(lines[k + 1]);
    if (!line) return InvalidArgumentError(lp[0].string() + ":" + std::to_string(k + 2), "expected 'IMAGE x y z'");
    Shot shot;
    shot.image = LpImage(dir, line->image);
    LOOM_ASSIGN_OR_RETURN(const Eigen::Vector3d towards, UnitDirection(line->direction, lp[0], k + 2));
    shot.towards_light = YUpToYDown(towards);
    shot.orthographic = true;
    capture.shots.push_back(shot);
  }
  if (fs::exists(dir / "mask.png")) capture.mask = dir / "mask.png";
  return capture;
}

Result<Eigen::Vector3d> Vector3(const nlohmann::json& j, const std::string& where) {
  if (!j.is_array() || j.size() != 3 || !j[0].is_number() || !j[1].is_number() || !j[2].is_number()) {
    return InvalidArgumentError(where, "expected [x, y, z]");
  }
  return Eigen::Vector3d(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
}

// The flash layout's numbers, from the text files or capture.json.
struct FlashNumbers {
  std::vector<Eigen::Vector3d> cameras_cm, lights_cm;
  double width_cm = 0;
  Eigen::Vector3d power = Eigen::Vector3d::Ones();
};

Result<FlashNumbers> ReadFlashJson(const fs::path& path) {
  LOOM_ASSIGN_OR_RETURN(const std::string text, ReadFile(path));
  const nlohmann::json json = nlohmann::json::parse(text, nullptr, false);
  if (json.is_discarded() || !json.is_object()) return InvalidArgumentError(path.string(), "not a JSON object");
  FlashNumbers numbers;
  for (const char* key : {"camera_pos", "light_pos", "image_size"}) {
    if (!json.contains(key)) return InvalidArgumentError(path.string(), std::string("missing key '") + key + "'");
  }
  for (const auto& [key, into] : {std::pair{"camera_pos", &numbers.cameras_cm}, {"light_pos", &numbers.lights_cm}}) {
    if (!json[key].is_array()) return InvalidArgumentError(path.string() + ": " + key, "expected a list of [x, y, z]");
    for (size_t i = 0; i < json[key].size(); ++i) {
      LOOM_ASSIGN_OR_RETURN(const Eigen::Vector3d v,
                            Vector3(json[key][i], path.string() + ": " + key + "[" + std::to_string(i) + "]"));
      into->push_back(v);
    }
  }
  if (!json["image_size"].is_number()) return InvalidArgumentError(path.string() + ": image_size", "expected the width in cm");
  numbers.width_cm = json["image_size"].get<double>();
  if (json.contains("light_power")) {
    LOOM_ASSIGN_OR_RETURN(numbers.power, Vector3(json["light_power"], path.string() + ": light_power"));
  }
  return numbers;
}

Result<FlashNumbers> ReadFlashText(const fs::path& dir) {
  FlashNumbers numbers;
  LOOM_ASSIGN_OR_RETURN(const auto cameras, ReadTable(dir / "camera_pos.txt", 3, -1, "a camera position x,y,z"));
  LOOM_ASSIGN_OR_RETURN(const auto lights,
                        ReadTable(dir / "light_pos.txt", 3, static_cast<int>(cameras.size()), "a light position x,y,z"));
  for (size_t k = 0; k < cameras.size(); ++k) {
    numbers.cameras_cm.emplace_back(cameras[k][0], cameras[k][1], cameras[k][2]);
    numbers.lights_cm.emplace_back(lights[k][0], lights[k][1], lights[k][2]);
  }
  LOOM_ASSIGN_OR_RETURN(const auto size, ReadTable(dir / "image_size.txt", 1, 1, "the sample's width in cm"));
  numbers.width_cm = size[0][0];
  if (fs::exists(dir / "light_power.txt")) {
    LOOM_ASSIGN_OR_RETURN(const auto power, ReadNumberRows(dir / "light_power.txt"));
    if (power.size() != 1 || (power[0].size() != 1 && power[0].size() != 3)) {
      return InvalidArgumentError((dir / "light_power.txt").string(), "expected one line: a power, or r,g,b");
    }
    numbers.power =
        power[0].size() == 3 ? Eigen::Vector3d(power[0][0], power[0][1], power[0][2]) : Eigen::Vector3d::Constant(power[0][0]);
  }
  return numbers;
}

// The images of a flash capture: NN.png etc., in name order, the mask left out.
std::vector<fs::path> FlashImages(const fs::path& dir) {
  std::vector<fs::path> images;
  for (const char* extension : {".png", ".jpg", ".jpeg", ".exr"}) {
    for (const fs::path& p : FilesEndingIn(dir, extension)) {
      if (p.stem() != "mask") images.push_back(p);
    }
  }
  std::sort(images.begin(), images.end());
  return images;
}

Result<Capture> ReadFlash(const fs::path& dir, const ImportOptions& options) {
  const fs::path json = dir / "capture.json";
  const fs::path source = fs::exists(json) ? json : dir / "camera_pos.txt";
  LOOM_ASSIGN_OR_RETURN(const FlashNumbers numbers, fs::exists(json) ? ReadFlashJson(json) : ReadFlashText(dir));
  const std::vector<fs::path> images = FlashImages(dir);
  if (images.size() != numbers.cameras_cm.size() || numbers.lights_cm.size() != numbers.cameras_cm.size()) {
    return InvalidArgumentError(source.string(), std::to_string(numbers.cameras_cm.size()) + " cameras and " +
                                                     std::to_string(numbers.lights_cm.size()) + " lights for " +
                                                     std::to_string(images.size()) + " images in " + dir.string());
  }
  if (!(numbers.width_cm > 0)) return InvalidArgumentError(source.string(), "the sample's width must be > 0 cm");
  if (!(numbers.power.minCoeff() > 0)) return InvalidArgumentError(source.string(), "the light's power must be > 0");
  Capture capture;
  capture.width_mm = 10 * numbers.width_cm;
  const Eigen::Vector3d offset_cm = options.flash_offset_cm.value_or(Eigen::Vector3d::Zero());
  for (size_t k = 0; k < images.size(); ++k) {
    Shot shot;
    shot.image = images[k];
    shot.camera_mm = YUpToYDown(10 * numbers.cameras_cm[k]);
    shot.light_mm = YUpToYDown(10 * (numbers.lights_cm[k] + offset_cm));
    if (!(shot.camera_mm.z() > 0 && shot.light_mm.z() > 0)) {
      return InvalidArgumentError(source.string(),
                                  "image " + std::to_string(k) + ": camera and light must be above the sample (z > 0)");
    }
    shot.intensity = numbers.power * 100;  // power per cm² at 1 cm → per mm²
    capture.shots.push_back(shot);
  }
  if (fs::exists(dir / "mask.png")) capture.mask = dir / "mask.png";
  return capture;
}

// ---- the flash's offset ----

// Where image `photo`'s highlight lies on the sample (stack frame, mm): the median position of its
// clipped pixels where it has enough of them, else of its brightest thousandth.
std::optional<Eigen::Vector2d> HighlightPosition(const Photo& photo, double width_mm) {
  constexpr int kEnoughClipped = 16;
  const cv::Mat& v = photo.values;
  const int channels = v.channels();
  std::vector<double> luminance(v.total());
  for (size_t p = 0; p < v.total(); ++p) {
    double sum = 0;
    for (int c = 0; c < channels; ++c) {
      const float value = v.ptr<float>()[p * channels + c];
      sum += std::isnan(value) ? 1.0 : value;  // clipped: at the top
    }
    luminance[p] = sum / channels;
  }
  std::vector<double> sorted = luminance;
  const auto top = sorted.begin() + static_cast<std::ptrdiff_t>(0.999 * static_cast<double>(sorted.size() - 1));
  std::nth_element(sorted.begin(), top, sorted.end());
  const double clipped = static_cast<double>(std::count(luminance.begin(), luminance.end(), 1.0));
  const double threshold = clipped >= kEnoughClipped ? 1.0 : *top;
  std::vector<double> xs, ys;
  const double pixel_mm = width_mm / v.cols;
  for (size_t p = 0; p < luminance.size(); ++p) {
    if (luminance[p] < threshold) continue;
    xs.push_back((static_cast<double>(p % v.cols) + 0.5 - v.cols / 2.0) * pixel_mm);
    ys.push_back((static_cast<double>(p / v.cols) + 0.5 - v.rows / 2.0) * pixel_mm);
  }
  if (xs.empty()) return std::nullopt;
  const auto median = [](std::vector<double> values) {
    std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2), values.end());
    return values[values.size() / 2];
  };
  return Eigen::Vector2d(median(xs), median(ys));
}

// The flash's offset from where the files put it (stack frame, mm; z 0): the mirror point of a
// flat sample for camera c and light l is (c·l_z + l·c_z)/(c_z + l_z), so a highlight found h
// away from it says the light is off by h·(c_z + l_z)/c_z; the median over the images whose
// mirror point lies in the central kCentralShare of the sample, the held-out image's left out.
// Nothing when none does.
constexpr double kCentralShare = 0.9;
std::optional<Eigen::Vector3d> EstimateFlashOffset(const std::vector<Shot>& shots, const std::vector<Result<Photo>>& photos,
                                                   double width_mm, std::optional<int> held_out,
                                                   std::vector<Eigen::Vector2d>& found) {
  std::vector<double> dx, dy;
  for (size_t k = 0; k < shots.size(); ++k) {
    if (held_out && static_cast<int>(k) == *held_out) continue;  // a view the fit must not have seen
    const Eigen::Vector3d& c = shots[k].camera_mm;
    const Eigen::Vector3d& l = shots[k].light_mm;
    const Eigen::Vector2d mirror = ((c * l.z() + l * c.z()) / (c.z() + l.z())).head<2>();
    // A highlight near the edge is cut by it on one side, which pulls its median toward the centre.
    if (mirror.cwiseAbs().maxCoeff() > kCentralShare / 2 * width_mm) continue;
    const std::optional<Eigen::Vector2d> highlight = HighlightPosition(*photos[k], width_mm);
    if (!highlight) continue;
    found.push_back(*highlight - mirror);
    const Eigen::Vector2d off = (*highlight - mirror) * (c.z() + l.z()) / c.z();
    dx.push_back(off.x()), dy.push_back(off.y());
  }
  if (dx.empty()) return std::nullopt;
  const auto median = [](std::vector<double> values) {
    std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2), values.end());
    return values[values.size() / 2];
  };
  return Eigen::Vector3d(median(dx), median(dy), 0);
}

// ---- the stack ----

// Block means of the seen values: stack pixel (i, j) of the image pixels [i·n, i·n + n) ×
// [j·n, j·n + n). NaN values (masked) are left out; the block is NaN where it has no seen value,
// or where one of its values is +∞ (clipped): that block's true mean lies above its seen values'
// by an unknown amount, so it is as unseen as the clipped value. Near a highlight, where the
// clipped values gather, the seen values' mean would read the block darker than it is.
float BlockMean(const cv::Mat& values, int channel, int i, int j, int n) {
  double sum = 0;
  int seen = 0;
  const int channels = values.channels();
  for (int y = j * n; y < (j + 1) * n; ++y) {
    const float* row = values.ptr<float>(y);
    for (int x = i * n; x < (i + 1) * n; ++x) {
      const float v = row[x * channels + channel];
      if (std::isinf(v)) return NAN;
      if (!std::isnan(v)) sum += v, ++seen;
    }
  }
  return seen ? static_cast<float>(sum / seen) : NAN;
}

StackObservation ObservationOf(const Shot& shot, int channel, int channels, const std::string& description) {
  StackObservation o;
  o.group = channels == 3 ? ObservationGroup::kColour : ObservationGroup::kMonochrome;
  o.camera = "photo";
  o.rgb_weights = channels == 3 ? Eigen::Vector3d(Eigen::Vector3d::Unit(channel)) : Eigen::Vector3d::Constant(1.0 / 3);
  o.description = description;
  if (shot.orthographic) {
    o.view_direction = Eigen::Vector3d::UnitZ();
  } else {
    o.camera_mm = shot.camera_mm;
  }
  const double intensity = channels == 3 ? shot.intensity[channel] : shot.intensity.mean();
  if (shot.towards_light) {
    o.emitters.push_back(PointEmitter::AtInfinity(*shot.towards_light, 1.0));  // intensities are divided out
  } else {
    // An isotropic flash (falloff exponent 0) pointing down at the sample.
    o.emitters.push_back({shot.light_mm, -Eigen::Vector3d::UnitZ(), intensity, 0.0});
  }
  return o;
}

Result<cv::Mat> ReadMask(const fs::path& path, int width, int height) {
  DeclaredImage declared = ReadDeclaredImage(path);
  declared.bits = 0;  // a mask of any depth is read as grey
  LOOM_RETURN_IF_ERROR(CheckDeclaredImage(path, declared));
  const cv::Mat mask = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
  if (mask.empty()) return InvalidArgumentError(path.string(), "not an image OpenCV reads");
  if (mask.cols != width || mask.rows != height) {
    return InvalidArgumentError(path.string(), std::to_string(mask.cols) + "x" + std::to_string(mask.rows) +
                                                   " px does not match the images' " + std::to_string(width) + "x" +
                                                   std::to_string(height));
  }
  return mask;
}

}  // namespace

std::string_view LayoutName(Layout layout) {
  switch (layout) {
    case Layout::kPhotometricStereo:
      return "ps";
    case Layout::kLightPositions:
      return "lp";
    case Layout::kFlash:
      return "flash";
  }
  return "?";
}

Result<Layout> ParseLayout(const std::string& name, const std::string& what) {
  for (Layout layout : {Layout::kPhotometricStereo, Layout::kLightPositions, Layout::kFlash}) {
    if (LayoutName(layout) == name) return layout;
  }
  return InvalidArgumentError(what + " " + name, "expected ps, lp or flash");
}

std::string Encoding::Name() const {
  switch (kind) {
    case Kind::kLinear:
      return "linear";
    case Kind::kSrgb:
      return "srgb";
    case Kind::kGamma: {
      std::ostringstream name;
      name << "gamma:" << gamma;
      return name.str();
    }
  }
  return "?";
}

Result<Eigen::Vector3d> ParseFlashOffset(const std::string& text, const std::string& what) {
  std::istringstream in(text);
  Eigen::Vector3d v;
  char comma1 = 0, comma2 = 0;
  if (!(in >> v.x() >> comma1 >> v.y() >> comma2 >> v.z()) || comma1 != ',' || comma2 != ',' || !in.eof() || !v.allFinite()) {
    return InvalidArgumentError(what + " " + text, "expected X,Y,Z in cm");
  }
  return v;
}

Result<Encoding> ParseEncoding(const std::string& text, const std::string& what) {
  if (text == "linear") return Encoding{};
  if (text == "srgb") return Encoding{Encoding::Kind::kSrgb, 1};
  if (text.starts_with("gamma:")) {
    double gamma = 0;
    const char* begin = text.data() + 6;
    const auto [end, error] = std::from_chars(begin, text.data() + text.size(), gamma);
    if (error == std::errc() && end == text.data() + text.size() && gamma > 0 && gamma <= 10) {
      return Encoding{Encoding::Kind::kGamma, gamma};
    }
  }
  return InvalidArgumentError(what + " " + text, "expected linear, srgb or gamma:G with G in (0, 10]");
}

Status ImportOptions::Check() const {
  std::vector<std::string> problems;
  if (downsample < 1 || downsample > 64) problems.push_back("downsample must be in [1, 64]");
  if (scale && !(*scale > 0 && std::isfinite(*scale))) problems.push_back("scale must be a finite number > 0");
  if (!(pixel_mm >= kMinStackPixelMm && pixel_mm <= kMaxStackPixelMm)) problems.push_back("pixel_mm must be in [0.001, 1000]");
  if (flash_offset_cm && !flash_offset_cm->allFinite()) problems.push_back("flash_offset_cm must be finite");
  if (threads < 0) problems.push_back("threads must be ≥ 0");
  if (hold_out && *hold_out < 0) problems.push_back("hold_out must be ≥ 0");
  return ProblemsStatus("ImportOptions", problems);
}

Result<Layout> DetectLayout(const fs::path& dir) {
  if (!fs::is_directory(dir)) return NotFoundError(dir.string(), "not a folder of photographs");
  if (fs::exists(dir / "filenames.txt") || fs::exists(dir / "light_directions.txt")) return Layout::kPhotometricStereo;
  if (!FilesEndingIn(dir, ".lp").empty()) return Layout::kLightPositions;
  if (fs::exists(dir / "camera_pos.txt") || fs::exists(dir / "light_pos.txt") || fs::exists(dir / "capture.json")) {
    return Layout::kFlash;
  }
  return InvalidArgumentError(dir.string(),
                              "no layout recognised: ps needs filenames.txt and light_directions.txt, lp a .lp file, flash "
                              "camera_pos.txt, light_pos.txt and image_size.txt (or capture.json)");
}

double AutomaticScale(const ObservationStack& stack, int threads) {
  const int width = stack.image.width();
  const int pixels = static_cast<int>(stack.image.pixel_count());
  std::vector<double> albedo(pixels, NAN);
  ParallelFor(pixels, threads, [&](int i) {
    const Eigen::Vector3d p = stack.Position(i % width, i / width);
    std::vector<double> values;
    for (size_t k = 0; k < stack.observations.size(); ++k) {
      const float v = stack.image.channel(ObservationStack::ObservationChannel(static_cast<int>(k)))[i];
      if (std::isnan(v)) continue;
      double irradiance = 0;
      for (const PointEmitter& e : stack.observations[k].emitters) irradiance += e.IrradianceAt(p);
      if (irradiance > 0) values.push_back(std::numbers::pi * v / irradiance);
    }
    if (values.empty()) return;
    const auto q = values.begin() + static_cast<std::ptrdiff_t>(0.9 * static_cast<double>(values.size() - 1));
    std::nth_element(values.begin(), q, values.end());
    albedo[i] = *q;
  });
  std::erase_if(albedo, [](double a) { return std::isnan(a); });
  if (albedo.empty()) return 1;
  const auto q = albedo.begin() + static_cast<std::ptrdiff_t>(0.99 * static_cast<double>(albedo.size() - 1));
  std::nth_element(albedo.begin(), q, albedo.end());
  return *q > kAlbedoTarget ? kAlbedoTarget / *q : 1.0;
}

Result<Image> ReadNormalMap(const fs::path& path, int downsample) {
  if (downsample < 1) return InvalidArgumentError(path.string(), "downsample must be ≥ 1");
  Photo photo;
  const bool exr = Lower(path.extension().string()) == ".exr";
  if (exr) {
    LOOM_ASSIGN_OR_RETURN(photo, ReadExrPhoto(path, {{"X", "Y", "Z"}, {"R", "G", "B"}}));
  } else {
    LOOM_ASSIGN_OR_RETURN(photo, ReadPhoto(path, /*mark_clipped=*/false));
  }
  if (photo.values.channels() != 3) return InvalidArgumentError(path.string(), "a normal map needs three channels");
  cv::Mat& values = photo.values;
  for (int y = 0; y < values.rows; ++y) {
    cv::Vec3f* row = values.ptr<cv::Vec3f>(y);
    for (int x = 0; x < values.cols; ++x) {
      cv::Vec3f& n = row[x];
      const bool none = !exr && n[0] == 0 && n[1] == 0 && n[2] == 0;
      if (!exr) n = n * 2.0f - cv::Vec3f(1, 1, 1);  // (n + 1)/2 stored
      if (none || !(cv::norm(n) > 0.5)) n = cv::Vec3f(NAN, NAN, NAN);
    }
  }
  const int width = values.cols / downsample, height = values.rows / downsample;
  Image normals(width, height, {"X", "Y", "Z"});
  for (int j = 0; j < height; ++j) {
    for (int i = 0; i < width; ++i) {
      Eigen::Vector3d n(BlockMean(values, 0, i, j, downsample), -BlockMean(values, 1, i, j, downsample),
                        BlockMean(values, 2, i, j, downsample));
      if (n.allFinite() && n.norm() > 0) n.normalize();
      for (int c = 0; c < 3; ++c) normals.at(c, j, i) = static_cast<float>(n[c]);
    }
  }
  return normals;
}

Result<ImportResult> ImportCapture(const fs::path& dir, const ImportOptions& options) {
  LOOM_RETURN_IF_ERROR(options.Check());
  const auto start = std::chrono::steady_clock::now();
  ImportResult result;
  if (options.layout) {
    if (!fs::is_directory(dir)) return NotFoundError(dir.string(), "not a folder of photographs");
    result.layout = *options.layout;
  } else {
    LOOM_ASSIGN_OR_RETURN(result.layout, DetectLayout(dir));
  }
  Capture capture;
  switch (result.layout) {
    case Layout::kPhotometricStereo: {
      LOOM_ASSIGN_OR_RETURN(capture, ReadPhotometricStereo(dir));
      break;
    }
    case Layout::kLightPositions: {
      LOOM_ASSIGN_OR_RETURN(capture, ReadLightPositions(dir));
      break;
    }
    case Layout::kFlash: {
      LOOM_ASSIGN_OR_RETURN(capture, ReadFlash(dir, options));
      break;
    }
  }
  const int count = static_cast<int>(capture.shots.size());
  result.images = count;
  if (options.hold_out && *options.hold_out >= count) {
    return InvalidArgumentError("hold_out " + std::to_string(*options.hold_out),
                                "the capture in " + dir.string() + " has images 0 to " + std::to_string(count - 1));
  }
  // Every image, in parallel (decoding is most of an import's time).
  std::vector<Result<Photo>> photos(count, InternalError("import", "not read"));
  ParallelFor(count, options.threads, [&](int k) { photos[k] = ReadPhoto(capture.shots[k].image); });
  for (int k = 0; k < count; ++k) LOOM_RETURN_IF_ERROR(photos[k].status());
  const bool flash_at_lens = std::all_of(capture.shots.begin(), capture.shots.end(),
                                         [](const Shot& s) { return (s.light_mm - s.camera_mm).norm() < 1e-6; });
  if (result.layout == Layout::kFlash && !options.flash_offset_cm && flash_at_lens && capture.width_mm) {
    std::vector<Eigen::Vector2d> found;
    if (const std::optional<Eigen::Vector3d> offset =
            EstimateFlashOffset(capture.shots, photos, *capture.width_mm, options.hold_out, found)) {
      for (Shot& shot : capture.shots) shot.light_mm += *offset;
      result.flash_offset_cm = YUpToYDown(*offset / 10);
      result.flash_offset_images = static_cast<int>(found.size());
    }
  } else if (options.flash_offset_cm) {
    result.flash_offset_cm = *options.flash_offset_cm;
  }
  const cv::Mat& first = photos[0]->values;
  for (int k = 1; k < count; ++k) {
    const Photo& photo = *photos[k];
    if (photo.values.size() != first.size() || photo.values.channels() != first.channels() || photo.bits != photos[0]->bits) {
      return InvalidArgumentError(capture.shots[k].image.string(),
                                  std::to_string(photo.values.cols) + "x" + std::to_string(photo.values.rows) + " px, " +
                                      std::to_string(photo.values.channels()) + " channels, " + std::to_string(photo.bits) +
                                      " bits: the first image (" + capture.shots[0].image.filename().string() + ") has " +
                                      std::to_string(first.cols) + "x" + std::to_string(first.rows) + " px, " +
                                      std::to_string(first.channels()) + " channels, " + std::to_string(photos[0]->bits) +
                                      " bits");
    }
  }
  const int n = options.downsample;
  const int width = first.cols / n, height = first.rows / n;
  if (width < 1 || height < 1) {
    return InvalidArgumentError(capture.shots[0].image.string(), "smaller than one --downsample block");
  }
  cv::Mat mask;
  if (capture.mask) {
    LOOM_ASSIGN_OR_RETURN(mask, ReadMask(*capture.mask, first.cols, first.rows));
  }
  result.encoding = options.encoding.value_or(DefaultEncoding(result.layout, photos[0]->bits));
  const int channels = first.channels();
  std::vector<StackObservation> table;
  for (int k = 0; k < count; ++k) {
    for (int c = 0; c < channels; ++c) {
      const std::string name = capture.shots[k].image.filename().string();
      table.push_back(ObservationOf(capture.shots[k], c, channels, channels == 3 ? name + " " + "RGB"[c] : name));
    }
  }
  const double pixel_mm = (capture.width_mm ? *capture.width_mm / first.cols : options.pixel_mm) * n;
  ObservationStack& stack = result.stack;
  stack = MakeObservationStack(width, height, pixel_mm, std::move(table));
  stack.rig = std::string(kImportedRigPrefix) + std::string(LayoutName(result.layout));
  stack.source = "loom import " + dir.string();
  for (int j = 0; j < height; ++j) {
    for (int i = 0; i < width; ++i) {
      stack.image.at(0, j, i) = static_cast<float>((i + 0.5 - width / 2.0) * pixel_mm);
      stack.image.at(1, j, i) = static_cast<float>((j + 0.5 - height / 2.0) * pixel_mm);
    }
  }
  // Decode, mask, divide by the light's intensity (ps), block-average: each image on a thread.
  ParallelFor(count, options.threads, [&](int k) {
    cv::Mat values = photos[k]->values;
    float* v = values.ptr<float>();
    for (size_t p = 0; p < values.total(); ++p) {
      const bool masked = !mask.empty() && mask.data[p] == 0;
      for (int c = 0; c < channels; ++c) {
        float& value = v[p * channels + c];
        if (masked) {
          value = NAN;
        } else if (std::isnan(value)) {
          // Clipped (ReadPhoto marks the top of an 8- or 16-bit range): BlockMean leaves its whole
          // block unseen. An EXR's NaN is a value not recorded, left out alone.
          if (photos[k]->bits != 32) value = INFINITY;
        } else {
          const Shot& shot = capture.shots[k];
          const double divide = shot.towards_light ? (channels == 3 ? shot.intensity[c] : shot.intensity.mean()) : 1.0;
          value = static_cast<float>(Decode(value, result.encoding) / divide);
        }
      }
    }
    for (int c = 0; c < channels; ++c) {
      const int channel = ObservationStack::ObservationChannel(k * channels + c);
      for (int j = 0; j < height; ++j) {
        for (int i = 0; i < width; ++i) stack.image.at(channel, j, i) = BlockMean(values, c, i, j, n);
      }
    }
  });
  for (int k = 0; k < count; ++k) result.clipped_values += photos[k]->clipped;
  photos.clear();
  result.scale_automatic = !options.scale;
  result.scale = options.scale ? *options.scale : AutomaticScale(stack, options.threads);
  for (size_t k = 0; k < stack.observations.size(); ++k) {
    for (float& v : stack.image.channel(ObservationStack::ObservationChannel(static_cast<int>(k)))) {
      v = static_cast<float>(v * result.scale);
    }
  }
  for (int j = 0; j < height; ++j) {
    for (int i = 0; i < width; ++i) {
      bool seen = false;
      for (size_t k = 0; k < stack.observations.size() && !seen; ++k) {
        seen = !std::isnan(stack.image.at(ObservationStack::ObservationChannel(static_cast<int>(k)), j, i));
      }
      result.masked_pixels += !seen;
    }
  }
  if (options.hold_out) {
    std::vector<int> kept, held;
    for (int k = 0; k < static_cast<int>(stack.observations.size()); ++k) {
      (k / channels == *options.hold_out ? held : kept).push_back(k);
    }
    result.held_out = SelectObservations(stack, held);
    stack = SelectObservations(stack, kept);
  }
  result.seconds = SecondsSince(start);
  return result;
}

nlohmann::json ImportResult::ToJson() const {
  return {{"layout", LayoutName(layout)},
          {"images", images},
          {"observations", stack.observations.size()},
          {"width", stack.image.width()},
          {"height", stack.image.height()},
          {"pixel_mm", stack.pixel_mm},
          {"encoding", encoding.Name()},
          {"masked_pixels", masked_pixels},
          {"clipped_values", clipped_values},
          {"scale", scale},
          {"scale_automatic", scale_automatic},
          {"flash_offset_cm", flash_offset_cm
                                  ? nlohmann::json::array({flash_offset_cm->x(), flash_offset_cm->y(), flash_offset_cm->z()})
                                  : nlohmann::json()},
          {"flash_offset_estimated_from", flash_offset_images},
          {"seconds", seconds}};
}

void ImportResult::Report(std::ostream& out) const {
  out << "imported " << images << " images (" << LayoutName(layout) << ", " << encoding.Name() << ") as "
      << stack.observations.size() << " observations on " << stack.image.width() << "x" << stack.image.height() << " px of "
      << stack.pixel_mm << " mm; " << masked_pixels << " px masked or unseen, " << clipped_values << " clipped values left out\n"
      << "radiance scale " << scale << (scale_automatic ? " (automatic: albedos within the model's bound)" : " (given)") << "; "
      << FormatDuration(seconds) << "\n";
  if (flash_offset_cm) {
    out << "flash offset from the lens " << flash_offset_cm->x() << ", " << flash_offset_cm->y() << ", " << flash_offset_cm->z()
        << " cm (x, y up, z)"
        << (flash_offset_images > 0 ? " estimated from the highlights of " + std::to_string(flash_offset_images) + " images"
                                    : std::string(" as given"))
        << "\n";
  }
}

}  // namespace loom::photos
