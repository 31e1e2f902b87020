#pragma once
// OpenEXR I/O for loom's images: multi-channel float or half images with named channels and
// typed header attributes. Used for HDR stacks (~1000 channels), SVBRDF parameter maps and
// heightmaps. OpenEXR stays behind this interface.
//
// - Channel order is preserved across a write/read round trip (EXR itself sorts channels by
//   name; loom records the order in the `loomChannelOrder` attribute).
// - Writes are atomic: the file is written under a temporary name in the same directory,
//   flushed to disk, then renamed, so a crash never leaves a half-written file at `path`.
// - Every failure names the file: missing, not an EXR, truncated, unreadable, disk full.
// - Matrices are stored as Imath M33d/M44d, transposed to Imath's row-vector convention, so
//   other EXR tools read them as the same transform; the round trip returns the Eigen matrix.
// Thread-safety: functions are reentrant; OpenEXR's internal thread pool is shared.

#include <cstdint>
#include <filesystem>
#include <map>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "core/status.h"

namespace loom {

using ExrAttribute = std::variant<std::string, int, float, double, Eigen::Vector3d, Eigen::Matrix3d, Eigen::Matrix4d>;
using ExrAttributes = std::map<std::string, ExrAttribute>;

enum class ExrPixelType { kFloat, kHalf };
enum class ExrCompression { kNone, kZip, kZips, kPiz, kRle };

struct ExrWriteOptions {
  // Storage type of every channel. Half keeps ~3 significant digits up to 65504: fine for
  // display images, not for radiance stacks or parameter maps (use float).
  ExrPixelType pixel_type = ExrPixelType::kFloat;
  // kZip: lossless, good on smooth maps, ~2–4× slower to write than kNone.
  ExrCompression compression = ExrCompression::kZip;
  Status Check() const;  // every problem, naming the field
};

struct ExrReadOptions {
  // Read only these channels, in this order (all channels when empty). A channel that is not
  // in the file is a NotFound error naming it and the file.
  std::vector<std::string> channels;
  Status Check() const;  // every problem, naming the field
};

struct ExrImage {
  Image image;
  ExrAttributes attributes;  // user attributes only (not EXR's required header fields)
};

struct ExrHeader {
  int width = 0;
  int height = 0;
  std::vector<std::string> channel_names;  // in loom's order when recorded, else EXR's
  ExrAttributes attributes;
};

// Sets the number of OpenEXR worker threads (0 = one per core, the default).
void SetExrThreadCount(int threads);

Status WriteExr(const std::filesystem::path& path, const Image& image, const ExrAttributes& attributes = {},
                const ExrWriteOptions& options = {});

Result<ExrImage> ReadExr(const std::filesystem::path& path, const ExrReadOptions& options = {});

// Reads the header only (fast: no pixel data).
Result<ExrHeader> ReadExrHeader(const std::filesystem::path& path);

// Whether `path` is an EXR that loom wrote: its header has an attribute whose name begins with
// "loom" (every WriteExr records the channel order as loomChannelOrder). False for anything else,
// unreadable files included.
bool IsLoomExr(const std::filesystem::path& path);

// One 16-bit integer channel stored losslessly (EXR UINT, ZIP): raw camera frames.
// Same atomicity and errors as WriteExr/ReadExr. Reading a value above 65535 is DataLoss.
Status WriteExrUint16(const std::filesystem::path& path, int width, int height, std::span<const uint16_t> pixels,
                      const std::string& channel, const ExrAttributes& attributes = {});
struct ExrUint16Image {
  int width = 0;
  int height = 0;
  std::vector<uint16_t> pixels;
  ExrAttributes attributes;
};
Result<ExrUint16Image> ReadExrUint16(const std::filesystem::path& path, const std::string& channel);

}  // namespace loom
