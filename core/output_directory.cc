#include "core/output_directory.h"

#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "core/file_io.h"

namespace loom {

namespace fs = std::filesystem;

namespace {

// Every partial directory staged, with its final path: errors are printed after the
// OutputDirectory that made them is gone.
struct StagedPaths {
  std::mutex mutex;
  std::vector<std::pair<std::string, std::string>> partial_and_final;
};

StagedPaths& Staged() {
  static StagedPaths* staged = new StagedPaths;  // never destroyed: errors are printed late
  return *staged;
}

fs::path WithoutTrailingSlash(const fs::path& directory) {
  return directory.has_filename() ? directory : directory.parent_path();
}

}  // namespace

Result<OutputDirectory> OutputDirectory::Create(const fs::path& directory, const std::string& what) {
  std::error_code error;
  const fs::path final_path = WithoutTrailingSlash(directory);
  LOOM_RETURN_IF_ERROR(CheckDirectoryOutputPath(final_path, what));
  if (fs::exists(final_path, error) && !(fs::is_directory(final_path, error) && fs::is_empty(final_path, error))) {
    return AlreadyExistsError(what + " " + final_path.string(),
                              "exists and is not an empty directory: outputs never replace what is there (remove it, "
                              "or pick another)");
  }
  return Stage(final_path, what, /*replaces=*/false);
}

Result<OutputDirectory> OutputDirectory::Replacing(const fs::path& directory, const std::string& what) {
  std::error_code error;
  const fs::path final_path = WithoutTrailingSlash(directory);
  LOOM_RETURN_IF_ERROR(CheckDirectoryOutputPath(final_path, what));
  if (fs::exists(final_path, error) && !fs::is_directory(final_path, error)) {
    return AlreadyExistsError(what + " " + final_path.string(), "exists and is not a directory: it is not replaced");
  }
  return Stage(final_path, what, /*replaces=*/true);
}

Result<OutputDirectory> OutputDirectory::Stage(const fs::path& final_path, const std::string& what, bool replaces) {
  std::error_code error;
  const fs::path parent = final_path.parent_path().empty() ? fs::path(".") : final_path.parent_path();
  const std::string prefix = "." + final_path.filename().string() + ".partial-";
  // Partial directories of earlier runs that failed or were killed (not those of a process still
  // writing this output).
  for (const fs::directory_entry& entry : fs::directory_iterator(parent, error)) {
    const std::string name = entry.path().filename().string();
    if (!name.starts_with(prefix)) continue;
    const pid_t writer = static_cast<pid_t>(std::atol(name.c_str() + prefix.size()));
    if (writer > 0 && (::kill(writer, 0) == 0 || errno == EPERM)) continue;
    fs::remove_all(entry.path(), error);
  }
  const fs::path partial = parent / (prefix + std::to_string(::getpid()));
  fs::create_directories(partial, error);
  if (error) {
    return IoError(what + " " + final_path.string(),
                   "cannot create the output (a hidden folder beside it first): " + error.message());
  }
  {
    std::lock_guard lock(Staged().mutex);
    Staged().partial_and_final.emplace_back(partial.string(), final_path.string());
  }
  return OutputDirectory(final_path, partial, replaces);
}

std::string OutputDirectory::InUsersTerms(std::string text) {
  std::lock_guard lock(Staged().mutex);
  for (const auto& [partial, final_path] : Staged().partial_and_final) {
    for (size_t at = text.find(partial); at != std::string::npos; at = text.find(partial, at + final_path.size())) {
      text.replace(at, partial.size(), final_path);
    }
  }
  return text;
}

OutputDirectory::OutputDirectory(OutputDirectory&& other) noexcept
    : final_(std::move(other.final_)),
      partial_(std::move(other.partial_)),
      replaces_(other.replaces_),
      committed_(other.committed_) {
  other.committed_ = true;  // the moved-from object owns nothing
}

OutputDirectory::~OutputDirectory() {
  if (committed_) return;
  std::error_code error;
  fs::remove_all(partial_, error);
}

Status OutputDirectory::Commit() {
  std::error_code error;
  if (replaces_ && fs::is_directory(final_, error)) {
    if (::renameat2(AT_FDCWD, partial_.c_str(), AT_FDCWD, final_.c_str(), RENAME_EXCHANGE) != 0) {
      return IoError(final_.string(),
                     std::string("cannot exchange the finished output for the old one: ") + std::strerror(errno));
    }
    committed_ = true;
    fs::remove_all(partial_, error);  // now the old output
    return Status::Ok();
  }
  fs::remove(final_, error);  // empty, if it exists
  fs::rename(partial_, final_, error);
  if (error) return IoError(final_.string(), "cannot move the finished output into place: " + error.message());
  committed_ = true;
  return Status::Ok();
}

}  // namespace loom
