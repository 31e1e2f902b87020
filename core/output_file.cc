#include "core/output_file.h"

#include <zlib.h>

#include <array>
#include <cstdint>
#include <fstream>

#include <nlohmann/json.hpp>

#include "core/exr_io.h"
#include "core/file_io.h"
#include "core/version.h"

namespace loom {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kPngSignature("\x89PNG\r\n\x1a\n", 8);
constexpr std::string_view kPngSoftwareKeyword("Software\0", 9);
// A JSON report larger than this is no loom report: not parsed to look for the marker.
constexpr uintmax_t kMaxMarkedJsonBytes = uintmax_t{64} << 20;

std::string FirstBytes(const fs::path& path, size_t count) {
  std::ifstream in(path, std::ios::binary);
  std::string bytes(count, '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(count));
  bytes.resize(static_cast<size_t>(in.gcount()));
  return bytes;
}

uint32_t ReadBigEndian32(std::string_view bytes) {
  uint32_t value = 0;
  for (const char byte : bytes.substr(0, 4)) value = (value << 8) | static_cast<uint8_t>(byte);
  return value;
}

void AppendBigEndian32(std::string& out, uint32_t value) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<char>((value >> shift) & 0xff));
}

// The PNG's chunks in its first bytes, looking for loom's "Software" text.
bool IsLoomPng(std::string_view bytes) {
  if (!bytes.starts_with(kPngSignature)) return false;
  size_t at = kPngSignature.size();
  while (at + 8 <= bytes.size()) {
    const uint32_t length = ReadBigEndian32(bytes.substr(at));
    const std::string_view type = bytes.substr(at + 4, 4);
    const std::string_view data = bytes.substr(at + 8, length);
    if (type == "tEXt" && data.starts_with(kPngSoftwareKeyword) && data.substr(kPngSoftwareKeyword.size()).starts_with("loom")) {
      return true;
    }
    if (type == "IDAT" || type == "IEND") return false;  // text after the pixels is not where loom puts it
    at += 12 + static_cast<size_t>(length);
  }
  return false;
}

bool IsLoomJson(const fs::path& path) {
  const Result<std::string> text = ReadFile(path, kMaxMarkedJsonBytes);
  if (!text.ok()) return false;
  const nlohmann::json document = nlohmann::json::parse(*text, nullptr, /*allow_exceptions=*/false);
  return document.is_object() && document.contains("loom_version");
}

}  // namespace

bool HasLoomMarker(const fs::path& path) {
  std::error_code error;
  if (!fs::is_regular_file(fs::symlink_status(path, error))) return false;  // a FIFO or device could read without end
  const std::string head = FirstBytes(path, 4096);
  if (head.starts_with(kPngSignature)) return IsLoomPng(head);
  if (head.starts_with(kLoomTextMarker)) return true;
  if (head.starts_with("v/1\x01")) return IsLoomExr(path);
  const size_t first = head.find_first_not_of(" \t\r\n");
  return first != std::string::npos && head[first] == '{' && IsLoomJson(path);
}

Status CheckOutputFile(const fs::path& path, const std::string& what, bool force, const LoomOutputTest& written_by_loom) {
  std::error_code error;
  const fs::file_status status = fs::symlink_status(path, error);
  if (error || !fs::exists(status)) return Status::Ok();
  LOOM_RETURN_IF_ERROR(CheckReplaceableFile(path));
  if (force || written_by_loom(path)) return Status::Ok();
  return FailedPreconditionError(what + " " + path.string(),
                                 "exists and is not a file loom wrote (it has no loom marker): nothing replaced; "
                                 "pick another path, or pass --force to replace it");
}

std::string MarkPngAsLoomOutput(std::string_view png) {
  constexpr size_t kHeaderChunkEnd = 8 + 4 + 4 + 13 + 4;  // signature, then IHDR: length, type, 13 bytes, CRC
  if (!png.starts_with(kPngSignature) || png.size() < kHeaderChunkEnd) return std::string(png);
  std::string chunk_body = "tEXt";
  chunk_body += kPngSoftwareKeyword;
  chunk_body += "loom ";
  chunk_body += VersionWithCommit();
  std::string marked(png.substr(0, kHeaderChunkEnd));
  AppendBigEndian32(marked, static_cast<uint32_t>(chunk_body.size() - 4));
  marked += chunk_body;
  AppendBigEndian32(marked, static_cast<uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(chunk_body.data()),
                                                        static_cast<uInt>(chunk_body.size()))));
  marked += png.substr(kHeaderChunkEnd);
  return marked;
}

}  // namespace loom
