#pragma once
// A command's output directory, written whole or not at all. The files go into a hidden sibling
// (".NAME.partial-PID"); Commit() renames it to NAME. A run that fails or is killed leaves no NAME
// that looks complete — only the partial directory, which the next run of the same output
// removes (unless the process that wrote it is still running). NAME must not exist or be empty: an output never replaces earlier
// results (or anything else a user keeps there). The exception is an output made to be
// replaced, such as a recalibration's radiometry/: Replacing() swaps it for the old one in one
// step, so a reader finds the old output or the new one whole, never a mix. A symbolic link,
// device, FIFO or socket at NAME is refused, never replaced; errors name NAME as the user gave it.

#include <filesystem>
#include <string>

#include "core/status.h"

namespace loom {

class OutputDirectory {
 public:
  // `what` names the option in errors ("--out").
  static Result<OutputDirectory> Create(const std::filesystem::path& directory, const std::string& what);
  // The same for an output that takes the place of the directory there, if any: Commit()
  // exchanges the two atomically (renameat2 RENAME_EXCHANGE) and then removes the old one.
  static Result<OutputDirectory> Replacing(const std::filesystem::path& directory, const std::string& what);

  OutputDirectory(OutputDirectory&& other) noexcept;
  OutputDirectory& operator=(OutputDirectory&&) = delete;
  OutputDirectory(const OutputDirectory&) = delete;
  ~OutputDirectory();  // removes the partial directory unless committed

  // Where to write until Commit().
  const std::filesystem::path& partial() const { return partial_; }
  // Renames the partial directory to the final name.
  Status Commit();

  // `text` (an error) with every partial directory this process staged named by its final path:
  // the user gave that path, and the hidden one is gone by the time the error is read.
  static std::string InUsersTerms(std::string text);

 private:
  OutputDirectory(std::filesystem::path final_path, std::filesystem::path partial, bool replaces)
      : final_(std::move(final_path)), partial_(std::move(partial)), replaces_(replaces) {}
  static Result<OutputDirectory> Stage(const std::filesystem::path& final_path, const std::string& what, bool replaces);
  std::filesystem::path final_;
  std::filesystem::path partial_;
  bool replaces_ = false;
  bool committed_ = false;
};

}  // namespace loom
