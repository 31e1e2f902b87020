#include "core/file_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/memory.h"

namespace loom {
namespace {

namespace fs = std::filesystem;

Status WriteAll(int fd, std::string_view data, const fs::path& path) {
  while (!data.empty()) {
    const ssize_t n = ::write(fd, data.data(), data.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      return IoError(path.string(), std::string("cannot write: ") + std::strerror(errno));
    }
    data.remove_prefix(static_cast<size_t>(n));
  }
  return Status::Ok();
}

Status SyncAndClose(int fd, const fs::path& path) {
  const int synced = ::fsync(fd);
  const int sync_errno = errno;
  const int closed = ::close(fd);
  if (synced != 0) return IoError(path.string(), std::string("fsync failed: ") + std::strerror(sync_errno));
  if (closed != 0) return IoError(path.string(), std::string("close failed: ") + std::strerror(errno));
  return Status::Ok();
}

const char* KindOfNonRegularFile(mode_t mode) {
  if (S_ISLNK(mode)) return "a symbolic link";
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "a device";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

}  // namespace

Status CheckReplaceableFile(const fs::path& path) {
  struct stat info {};
  if (::lstat(path.c_str(), &info) != 0) return Status::Ok();  // new, or its folder's error comes when it is created
  if (S_ISREG(info.st_mode)) return Status::Ok();
  return FailedPreconditionError(path.string(), std::string("is ") + KindOfNonRegularFile(info.st_mode) +
                                                    ": an output file replaces only a regular file (pick another path)");
}

Status CheckDirectoryOutputPath(const fs::path& path, const std::string& what) {
  struct stat info {};
  if (::lstat(path.c_str(), &info) != 0 || S_ISDIR(info.st_mode) || S_ISREG(info.st_mode)) return Status::Ok();
  return FailedPreconditionError(what + " " + path.string(), std::string("is ") + KindOfNonRegularFile(info.st_mode) +
                                                                 ": an output never replaces one (pick another path)");
}

Status CheckOutputFolderExists(const fs::path& path, const std::string& what) {
  const fs::path folder = path.parent_path().empty() ? fs::path(".") : path.parent_path();
  std::error_code error;
  if (fs::is_directory(folder, error)) return Status::Ok();
  return NotFoundError(what + " " + path.string(), "its folder " + folder.string() + " does not exist: nothing written");
}

Status WriteFileAtomically(const fs::path& path, std::string_view text) {
  LOOM_RETURN_IF_ERROR(CheckReplaceableFile(path));
  const fs::path temporary = path.parent_path() / ("." + path.filename().string() + ".tmp-" + std::to_string(::getpid()));
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return IoError(path.string(), std::string("cannot create: ") + std::strerror(errno));
  Status written = WriteAll(fd, text, path);
  const Status closed = SyncAndClose(fd, path);
  if (written.ok()) written = closed;
  std::error_code ec;
  if (written.ok()) {
    fs::rename(temporary, path, ec);
    if (ec) written = IoError(path.string(), "cannot rename into place: " + ec.message());
  }
  if (!written.ok()) {
    fs::remove(temporary, ec);
    return written;
  }
  const int dir = ::open(path.parent_path().empty() ? "." : path.parent_path().c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
  return Status::Ok();
}

Status AppendLineDurably(const fs::path& path, std::string_view line) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0) return IoError(path.string(), std::string("cannot open for appending: ") + std::strerror(errno));
  std::string record(line);
  record += '\n';
  const Status written = WriteAll(fd, record, path);
  const Status closed = SyncAndClose(fd, path);
  return written.ok() ? closed : written;
}

Status CreateDirectories(const fs::path& directory) {
  std::error_code error;
  fs::create_directories(directory, error);
  if (error) return IoError(directory.string(), "cannot create the directory: " + error.message());
  return Status::Ok();
}

Result<std::string> ReadFile(const fs::path& path, uintmax_t max_bytes) {
  std::error_code ec;
  if (fs::exists(path, ec) && !fs::is_regular_file(path, ec)) return InvalidArgumentError(path.string(), "not a regular file");
  if (const uintmax_t bytes = fs::file_size(path, ec); !ec && bytes > max_bytes) {
    return InvalidArgumentError(
        path.string(), ReadableBytes(bytes) + ": larger than the " + ReadableBytes(max_bytes) + " loom reads for such a file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    if (!fs::exists(path, ec)) return NotFoundError(path.string(), "no such file");
    return IoError(path.string(), "cannot open for reading");
  }
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace loom
