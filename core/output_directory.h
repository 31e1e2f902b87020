#pragma once
// A command's output directory, written whole or not at all. The files go into a hidden sibling
// (".NAME.partial-PID"); Commit() renames it to NAME. A run that fails or is killed leaves no NAME
// that looks complete — only the partial directory, which the next run of the same output
// removes (unless the process that wrote it is still running). NAME must not exist or be empty: an output never replaces earlier
// results (or anything else a user keeps there).

#include <filesystem>

#include "core/status.h"

namespace loom {

class OutputDirectory {
 public:
  // `what` names the option in errors ("--out").
  static Result<OutputDirectory> Create(const std::filesystem::path& directory, const std::string& what);

  OutputDirectory(OutputDirectory&& other) noexcept;
  OutputDirectory& operator=(OutputDirectory&&) = delete;
  OutputDirectory(const OutputDirectory&) = delete;
  ~OutputDirectory();  // removes the partial directory unless committed

  // Where to write until Commit().
  const std::filesystem::path& partial() const { return partial_; }
  // Renames the partial directory to the final name.
  Status Commit();

 private:
  OutputDirectory(std::filesystem::path final_path, std::filesystem::path partial)
      : final_(std::move(final_path)), partial_(std::move(partial)) {}
  std::filesystem::path final_;
  std::filesystem::path partial_;
  bool committed_ = false;
};

}  // namespace loom
