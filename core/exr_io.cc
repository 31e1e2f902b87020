#include "core/exr_io.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <set>
#include <thread>

#include <Imath/half.h>
#include <ImfChannelList.h>
#include <ImfDoubleAttribute.h>
#include <ImfFloatAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfIntAttribute.h>
#include <ImfMatrixAttribute.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <ImfStringVectorAttribute.h>
#include <ImfTestFile.h>
#include <ImfThreading.h>
#include <ImfVecAttribute.h>
#include <openexr.h>

#include "core/file_io.h"
#include "core/log.h"

namespace loom {
namespace {

namespace fs = std::filesystem;

// Where loom records the channel order (EXR's channel list is sorted by name).
constexpr char kChannelOrderAttribute[] = "loomChannelOrder";

// Header fields every EXR has; they are not user attributes.
const std::set<std::string, std::less<>>& StandardAttributeNames() {
  static const std::set<std::string, std::less<>> names = {
      "channels",          "compression", "dataWindow", "displayWindow", "lineOrder", "pixelAspectRatio", "screenWindowCenter",
      "screenWindowWidth", "tiles",       "type",       "name",          "version",   "chunkCount",       kChannelOrderAttribute};
  return names;
}

std::once_flag g_threads_once;

void EnsureThreadPool() {
  std::call_once(g_threads_once, [] {
    if (Imf::globalThreadCount() == 0) {
      Imf::setGlobalThreadCount(static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
    }
  });
}

Imf::Compression ToImf(ExrCompression compression) {
  switch (compression) {
    case ExrCompression::kNone:
      return Imf::NO_COMPRESSION;
    case ExrCompression::kZip:
      return Imf::ZIP_COMPRESSION;
    case ExrCompression::kZips:
      return Imf::ZIPS_COMPRESSION;
    case ExrCompression::kPiz:
      return Imf::PIZ_COMPRESSION;
    case ExrCompression::kRle:
      return Imf::RLE_COMPRESSION;
  }
  return Imf::ZIP_COMPRESSION;
}

// Eigen (column-vector) matrix → Imath (row-vector) matrix: the transpose.
template <typename ImathMatrix, typename EigenMatrix>
ImathMatrix ToImath(const EigenMatrix& m) {
  ImathMatrix out;
  for (int r = 0; r < m.rows(); ++r) {
    for (int c = 0; c < m.cols(); ++c) out[c][r] = m(r, c);
  }
  return out;
}

template <typename EigenMatrix, typename ImathMatrix>
EigenMatrix FromImath(const ImathMatrix& m) {
  EigenMatrix out;
  for (int r = 0; r < out.rows(); ++r) {
    for (int c = 0; c < out.cols(); ++c) out(r, c) = m[c][r];
  }
  return out;
}

void InsertAttribute(Imf::Header& header, const std::string& name, const ExrAttribute& value) {
  struct Inserter {
    Imf::Header& header;
    const std::string& name;
    void operator()(const std::string& v) { header.insert(name, Imf::StringAttribute(v)); }
    void operator()(int v) { header.insert(name, Imf::IntAttribute(v)); }
    void operator()(float v) { header.insert(name, Imf::FloatAttribute(v)); }
    void operator()(double v) { header.insert(name, Imf::DoubleAttribute(v)); }
    void operator()(const Eigen::Vector3d& v) { header.insert(name, Imf::V3dAttribute(Imath::V3d(v.x(), v.y(), v.z()))); }
    void operator()(const Eigen::Matrix3d& v) { header.insert(name, Imf::M33dAttribute(ToImath<Imath::M33d>(v))); }
    void operator()(const Eigen::Matrix4d& v) { header.insert(name, Imf::M44dAttribute(ToImath<Imath::M44d>(v))); }
  };
  std::visit(Inserter{header, name}, value);
}

// Converts the user attributes of a header; attribute types loom does not use are skipped.
ExrAttributes ReadAttributes(const Imf::Header& header) {
  ExrAttributes attributes;
  for (auto it = header.begin(); it != header.end(); ++it) {
    const std::string name = it.name();
    if (StandardAttributeNames().contains(name)) continue;
    const Imf::Attribute& a = it.attribute();
    if (auto* s = dynamic_cast<const Imf::StringAttribute*>(&a)) {
      attributes[name] = s->value();
    } else if (auto* i = dynamic_cast<const Imf::IntAttribute*>(&a)) {
      attributes[name] = i->value();
    } else if (auto* f = dynamic_cast<const Imf::FloatAttribute*>(&a)) {
      attributes[name] = f->value();
    } else if (auto* d = dynamic_cast<const Imf::DoubleAttribute*>(&a)) {
      attributes[name] = d->value();
    } else if (auto* v3d = dynamic_cast<const Imf::V3dAttribute*>(&a)) {
      attributes[name] = Eigen::Vector3d(v3d->value().x, v3d->value().y, v3d->value().z);
    } else if (auto* v3f = dynamic_cast<const Imf::V3fAttribute*>(&a)) {
      attributes[name] = Eigen::Vector3d(v3f->value().x, v3f->value().y, v3f->value().z);
    } else if (auto* m3d = dynamic_cast<const Imf::M33dAttribute*>(&a)) {
      attributes[name] = FromImath<Eigen::Matrix3d>(m3d->value());
    } else if (auto* m3f = dynamic_cast<const Imf::M33fAttribute*>(&a)) {
      attributes[name] = FromImath<Eigen::Matrix3d>(m3f->value());
    } else if (auto* m4d = dynamic_cast<const Imf::M44dAttribute*>(&a)) {
      attributes[name] = FromImath<Eigen::Matrix4d>(m4d->value());
    } else if (auto* m4f = dynamic_cast<const Imf::M44fAttribute*>(&a)) {
      attributes[name] = FromImath<Eigen::Matrix4d>(m4f->value());
    } else {
      LOOM_LOG(Debug) << "skipping EXR attribute '" << name << "' of type " << a.typeName();
    }
  }
  return attributes;
}

// Channel names in loom's recorded order when present and consistent, else EXR's sorted order.
std::vector<std::string> ChannelOrder(const Imf::Header& header) {
  std::vector<std::string> sorted;
  for (auto it = header.channels().begin(); it != header.channels().end(); ++it) {
    sorted.emplace_back(it.name());
  }
  const auto* order = header.findTypedAttribute<Imf::StringVectorAttribute>(kChannelOrderAttribute);
  if (order == nullptr || order->value().size() != sorted.size()) return sorted;
  const std::set<std::string> recorded(order->value().begin(), order->value().end());
  if (recorded != std::set<std::string>(sorted.begin(), sorted.end())) return sorted;
  return order->value();
}

// The largest image loom reads, in either dimension: beyond every sensor and stack it makes.
constexpr int kMaxExrSide = 1 << 16;

// OpenEXR's C++ reader allocates an attribute's declared size before reading it, so a damaged
// header can make it ask for 2 GB (found by core/fuzz/stack_fuzzer.cc). OpenEXRCore, with a
// strict header, checks every size against the file first and refuses what does not fit.
Status CheckHeaderSizes(const fs::path& path) {
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.flags = EXR_CONTEXT_FLAG_STRICT_HEADER | EXR_CONTEXT_FLAG_SILENT_HEADER_PARSE;
  init.max_image_width = init.max_image_height = kMaxExrSide;
  init.max_tile_width = init.max_tile_height = kMaxExrSide;
  init.error_handler_fn = [](exr_const_context_t, exr_result_t, const char*) {};  // the status says it
  exr_context_t context = nullptr;
  const exr_result_t result = exr_start_read(&context, path.c_str(), &init);
  if (context != nullptr) exr_finish(&context);
  if (result != EXR_ERR_SUCCESS) {
    return DataLossError(path.string(), std::string("corrupt EXR header: ") + exr_get_default_error_message(result));
  }
  return Status::Ok();
}

Status CheckReadableExr(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return NotFoundError(path.string(), "no such file");
  if (!fs::is_regular_file(path, ec)) return InvalidArgumentError(path.string(), "not a regular file");
  if (::access(path.c_str(), R_OK) != 0) {
    return IoError(path.string(), std::string("cannot read: ") + std::strerror(errno));
  }
  if (!Imf::isOpenExrFile(path.c_str())) {
    return InvalidArgumentError(path.string(), "not an OpenEXR file (bad magic number)");
  }
  return CheckHeaderSizes(path);
}

Status FsyncFile(const fs::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return IoError(path.string(), std::string("cannot open to sync: ") + std::strerror(errno));
  const int rc = ::fsync(fd);
  const int saved_errno = errno;
  ::close(fd);
  if (rc != 0) return IoError(path.string(), std::string("fsync failed: ") + std::strerror(saved_errno));
  return Status::Ok();
}

fs::path TemporaryPathFor(const fs::path& path);

Status CheckAttributeNames(const fs::path& path, const ExrAttributes& attributes) {
  for (const auto& [name, value] : attributes) {
    if (StandardAttributeNames().contains(name)) {
      return InvalidArgumentError(path.string(), "attribute '" + name + "' is reserved by OpenEXR");
    }
  }
  return Status::Ok();
}

// Makes a rename durable: the directory entry itself must reach the disk.
void FsyncDirectory(const fs::path& directory) {
  const int fd = ::open(directory.empty() ? "." : directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

// Writes `path` through a temporary file: write, verify, fsync, rename, fsync the directory.
template <typename WriteFn>
Status WriteAtomically(const fs::path& path, WriteFn write) {
  LOOM_RETURN_IF_ERROR(CheckReplaceableFile(path));
  EnsureThreadPool();
  const fs::path temporary = TemporaryPathFor(path);
  std::error_code ec;
  try {
    write(temporary);
    // OpenEXR's destructor may swallow a failed final write (e.g. a full disk): re-open and
    // check that every scanline's offset landed before the file replaces anything.
    if (!Imf::InputFile(temporary.c_str()).isComplete()) {
      fs::remove(temporary, ec);
      return IoError(path.string(), "write incomplete (disk full?)");
    }
  } catch (const std::exception& e) {
    fs::remove(temporary, ec);
    return IoError(path.string(), std::string("cannot write: ") + e.what());
  }
  if (Status synced = FsyncFile(temporary); !synced.ok()) {
    fs::remove(temporary, ec);
    return IoError(path.string(), synced.message());
  }
  fs::rename(temporary, path, ec);
  if (ec) {
    fs::remove(temporary, ec);
    return IoError(path.string(), "cannot rename temporary file into place: " + ec.message());
  }
  FsyncDirectory(path.parent_path());
  return Status::Ok();
}

fs::path TemporaryPathFor(const fs::path& path) {
  return path.parent_path() / ("." + path.filename().string() + ".tmp-" + std::to_string(::getpid()));
}

void WritePixels(const fs::path& file_path, const Image& image, const ExrAttributes& attributes, const ExrWriteOptions& options) {
  Imf::Header header(image.width(), image.height());
  header.compression() = ToImf(options.compression);
  const Imf::PixelType stored = options.pixel_type == ExrPixelType::kHalf ? Imf::HALF : Imf::FLOAT;
  // OpenEXR's writer does not convert pixel types: half channels need half buffers.
  std::vector<half> half_pixels;
  if (stored == Imf::HALF) half_pixels.assign(image.data(), image.data() + image.pixel_count() * image.num_channels());
  Imf::FrameBuffer frame_buffer;
  for (int c = 0; c < image.num_channels(); ++c) {
    const std::string& name = image.channel_name(c);
    header.channels().insert(name, Imf::Channel(stored));
    // The writer only reads from the slices.
    char* base = stored == Imf::HALF ? reinterpret_cast<char*>(half_pixels.data() + c * image.pixel_count())
                                     : reinterpret_cast<char*>(const_cast<float*>(image.channel(c).data()));
    const size_t pixel_size = stored == Imf::HALF ? sizeof(half) : sizeof(float);
    frame_buffer.insert(name, Imf::Slice(stored, base, pixel_size, pixel_size * image.width()));
  }
  header.insert(kChannelOrderAttribute, Imf::StringVectorAttribute(image.channel_names()));
  for (const auto& [name, value] : attributes) InsertAttribute(header, name, value);
  Imf::OutputFile file(file_path.c_str(), header);
  file.setFrameBuffer(frame_buffer);
  file.writePixels(image.height());
}

}  // namespace

Status ExrWriteOptions::Check() const {
  std::vector<std::string> problems;
  if (pixel_type != ExrPixelType::kFloat && pixel_type != ExrPixelType::kHalf) {
    problems.push_back("pixel_type must be kFloat or kHalf");
  }
  if (static_cast<int>(compression) < static_cast<int>(ExrCompression::kNone) ||
      static_cast<int>(compression) > static_cast<int>(ExrCompression::kRle)) {
    problems.push_back("compression must be one of kNone, kZip, kZips, kPiz, kRle");
  }
  return ProblemsStatus("ExrWriteOptions", problems);
}

Status ExrReadOptions::Check() const {
  std::vector<std::string> problems;
  std::set<std::string> seen;
  for (const std::string& name : channels) {
    if (name.empty()) problems.push_back("channels holds an empty name");
    if (!seen.insert(name).second) problems.push_back("channels names '" + name + "' twice");
  }
  return ProblemsStatus("ExrReadOptions", problems);
}

void SetExrThreadCount(int threads) {
  std::call_once(g_threads_once, [] {});
  Imf::setGlobalThreadCount(threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
}

Status WriteExr(const fs::path& path, const Image& image, const ExrAttributes& attributes, const ExrWriteOptions& options) {
  if (image.empty()) {
    return InvalidArgumentError(path.string(), "refusing to write an empty image (" + std::to_string(image.width()) + "x" +
                                                   std::to_string(image.height()) + ", " + std::to_string(image.num_channels()) +
                                                   " channels)");
  }
  LOOM_RETURN_IF_ERROR(CheckAttributeNames(path, attributes));
  LOOM_RETURN_IF_ERROR(options.Check());
  return WriteAtomically(path, [&](const fs::path& temporary) { WritePixels(temporary, image, attributes, options); });
}

Result<ExrHeader> ReadExrHeader(const fs::path& path) {
  LOOM_RETURN_IF_ERROR(CheckReadableExr(path));
  try {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i window = file.header().dataWindow();
    ExrHeader header;
    header.width = window.max.x - window.min.x + 1;
    header.height = window.max.y - window.min.y + 1;
    header.channel_names = ChannelOrder(file.header());
    header.attributes = ReadAttributes(file.header());
    return header;
  } catch (const std::exception& e) {
    return DataLossError(path.string(), std::string("corrupt EXR header: ") + e.what());
  }
}

Result<ExrImage> ReadExr(const fs::path& path, const ExrReadOptions& options) {
  LOOM_RETURN_IF_ERROR(options.Check());
  LOOM_RETURN_IF_ERROR(CheckReadableExr(path));
  EnsureThreadPool();
  try {
    Imf::InputFile file(path.c_str());
    if (!file.isComplete()) {
      return DataLossError(path.string(), "truncated or incomplete: some scanlines were never written");
    }
    const Imf::Header& header = file.header();
    std::vector<std::string> names = options.channels.empty() ? ChannelOrder(header) : options.channels;
    for (const std::string& name : names) {
      const Imf::Channel* channel = header.channels().findChannel(name);
      if (channel == nullptr) return NotFoundError(path.string(), "no channel '" + name + "'");
      if (channel->xSampling != 1 || channel->ySampling != 1) {
        return InvalidArgumentError(path.string(), "channel '" + name + "' is subsampled (not supported)");
      }
    }
    const Imath::Box2i window = header.dataWindow();
    const int width = window.max.x - window.min.x + 1;
    const int height = window.max.y - window.min.y + 1;
    ExrImage result{Image(width, height, std::move(names)), ReadAttributes(header)};
    Imf::FrameBuffer frame_buffer;
    for (int c = 0; c < result.image.num_channels(); ++c) {
      frame_buffer.insert(result.image.channel_name(c), Imf::Slice::Make(Imf::FLOAT, result.image.channel(c).data(), window,
                                                                         sizeof(float), sizeof(float) * width));
    }
    file.setFrameBuffer(frame_buffer);
    file.readPixels(window.min.y, window.max.y);
    return result;
  } catch (const std::exception& e) {
    return DataLossError(path.string(), std::string("corrupt or truncated EXR: ") + e.what());
  }
}

bool IsLoomExr(const fs::path& path) {
  if (!CheckReadableExr(path).ok()) return false;
  try {
    const Imf::InputFile file(path.c_str());
    for (auto attribute = file.header().begin(); attribute != file.header().end(); ++attribute) {
      if (std::string_view(attribute.name()).starts_with("loom")) return true;
    }
  } catch (const std::exception&) {
  }
  return false;
}

Status WriteExrUint16(const fs::path& path, int width, int height, std::span<const uint16_t> pixels, const std::string& channel,
                      const ExrAttributes& attributes) {
  if (width <= 0 || height <= 0 || pixels.size() != static_cast<size_t>(width) * height) {
    return InvalidArgumentError(path.string(), "frame of " + std::to_string(pixels.size()) + " pixels is not " +
                                                   std::to_string(width) + "x" + std::to_string(height));
  }
  LOOM_RETURN_IF_ERROR(CheckAttributeNames(path, attributes));
  return WriteAtomically(path, [&](const fs::path& temporary) {
    // EXR has no 16-bit integer type: UINT (32-bit) holds the values exactly; ZIP keeps it small.
    std::vector<uint32_t> values(pixels.begin(), pixels.end());
    Imf::Header header(width, height);
    header.compression() = Imf::ZIP_COMPRESSION;
    header.channels().insert(channel, Imf::Channel(Imf::UINT));
    for (const auto& [name, value] : attributes) InsertAttribute(header, name, value);
    Imf::FrameBuffer frame_buffer;
    frame_buffer.insert(
        channel, Imf::Slice(Imf::UINT, reinterpret_cast<char*>(values.data()), sizeof(uint32_t), sizeof(uint32_t) * width));
    Imf::OutputFile file(temporary.c_str(), header);
    file.setFrameBuffer(frame_buffer);
    file.writePixels(height);
  });
}

Result<ExrUint16Image> ReadExrUint16(const fs::path& path, const std::string& channel) {
  LOOM_RETURN_IF_ERROR(CheckReadableExr(path));
  EnsureThreadPool();
  try {
    Imf::InputFile file(path.c_str());
    if (!file.isComplete()) return DataLossError(path.string(), "truncated or incomplete: some scanlines were never written");
    const Imf::Channel* stored = file.header().channels().findChannel(channel);
    if (stored == nullptr) return NotFoundError(path.string(), "no channel '" + channel + "'");
    if (stored->type != Imf::UINT) return InvalidArgumentError(path.string(), "channel '" + channel + "' is not UINT");
    const Imath::Box2i window = file.header().dataWindow();
    ExrUint16Image image;
    image.width = window.max.x - window.min.x + 1;
    image.height = window.max.y - window.min.y + 1;
    std::vector<uint32_t> values(static_cast<size_t>(image.width) * image.height);
    Imf::FrameBuffer frame_buffer;
    frame_buffer.insert(channel,
                        Imf::Slice::Make(Imf::UINT, values.data(), window, sizeof(uint32_t), sizeof(uint32_t) * image.width));
    file.setFrameBuffer(frame_buffer);
    file.readPixels(window.min.y, window.max.y);
    image.pixels.resize(values.size());
    for (size_t i = 0; i < values.size(); ++i) {
      if (values[i] > 0xFFFF) return DataLossError(path.string(), "value " + std::to_string(values[i]) + " exceeds 16 bits");
      image.pixels[i] = static_cast<uint16_t>(values[i]);
    }
    image.attributes = ReadAttributes(file.header());
    return image;
  } catch (const std::exception& e) {
    return DataLossError(path.string(), std::string("corrupt or truncated EXR: ") + e.what());
  }
}

}  // namespace loom
