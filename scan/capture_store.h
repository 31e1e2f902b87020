#pragma once
// CaptureStore: a scan on disk, crash-safe and append-only.
//
//   SCAN/scan.yaml       what was scanned: the rig YAML (snapshot), the object, loom's version and
//                        the plan's summary (written once, atomically)
//   SCAN/plan.yaml       the expanded plan, step by step (plan.h's PlanToYaml)
//   SCAN/frames/         raw frames, s<step>_<camera>_e<exposure>.exr: one UINT channel "DN",
//                        lossless, never rewritten
//   SCAN/journal.jsonl   one JSON record per frame: what the devices really did, the file and a
//                        checksum of its pixels; and one per completed step. A hash chain runs
//                        through the lines (each ends in "chain", the FNV-1a 64 of the previous
//                        link and its record)
//   SCAN/writer.lock     held (flock, exclusive) by the one process writing the scan; the kernel
//                        releases it when that process ends, however it ends
//
// Order of a write: the frame file (temporary name, fsync, rename, fsync of the directory),
// then its journal record (appended, fsync). A frame without a record is partial and is redone
// on resume; a torn last journal line (a crash mid-append) is dropped. Reading checks every
// journal line: a broken chain (an edited, inserted, removed or reordered line), a frame
// recorded twice, a step done twice, or a record the plan cannot have made (a step, camera or
// exposure it lacks) is an error naming the journal and the line. Reading a frame verifies it
// against its record: a missing, truncated or altered frame is an error naming the file.
// One writer per scan: Create and Open(repair) take the writer lock, and a second writer (a
// second `loom scan --resume` on the same directory) is refused naming the directory. Not
// thread-safe.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <ostream>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/status.h"
#include "scan/frame.h"
#include "scan/plan.h"

namespace loom::scan {

struct FrameKey {
  int step = 0;
  std::string camera;
  int exposure = 0;  // index in the step's HDR bracket
  auto operator<=>(const FrameKey&) const = default;
};

struct FrameRecord {
  FrameKey key;
  std::string file;      // relative to the scan directory
  std::string checksum;  // FNV-1a 64 of the pixels, hex
  int width = 0;
  int height = 0;
  FrameMetadata metadata;
};

struct ScanInfo {
  std::string rig_yaml;  // the rig file's text
  std::string object;    // what was on the turntable
  Plan plan;             // what was planned (purpose, preset, steps)
  double crop_mm = 0;    // > 0: a square crop of the sample, each camera reading only its window
};

class CaptureStore {
 public:
  // A new scan in `directory` (created; must not exist or be empty), locked for writing.
  static Result<CaptureStore> Create(const std::filesystem::path& directory, const ScanInfo& info);
  // An existing scan, for reading or resuming: reads scan.yaml and the journal. With
  // `repair` (resuming), takes the writer lock first (FailedPrecondition while another process
  // holds it), then drops a torn last journal line from the file and deletes partial frames.
  static Result<CaptureStore> Open(const std::filesystem::path& directory, bool repair = false);

  const std::filesystem::path& directory() const { return directory_; }
  const ScanInfo& info() const { return info_; }
  const std::vector<FrameRecord>& records() const { return records_; }
  bool Has(const FrameKey& key) const;

  // Stores a frame durably, then records it. A key already stored is AlreadyExists.
  Status Append(const FrameKey& key, const RawFrame& frame);
  // Records that every frame of `step` is stored (its HDR bracket is complete).
  Status MarkStepDone(int step);
  bool StepDone(int step) const { return done_steps_.contains(step); }
  int steps_done() const { return static_cast<int>(done_steps_.size()); }

  // The frame of a record, verified against its checksum.
  Result<RawFrame> ReadFrame(const FrameRecord& record) const;
  // The journal ended in a torn line when it was opened read-only (a repairing Open drops it).
  bool torn_last_line() const { return torn_last_line_; }
  // Files in frames/ that no record names: partial frames of the store's (a resume deletes
  // them) and files the store never writes (left alone). Sorted.
  struct UnrecordedFiles {
    std::vector<std::filesystem::path> partial;
    std::vector<std::filesystem::path> foreign;
  };
  UnrecordedFiles Unrecorded() const;

 private:
  explicit CaptureStore(std::filesystem::path directory) : directory_(std::move(directory)) {}
  std::filesystem::path JournalPath() const { return directory_ / "journal.jsonl"; }
  // Reads the journal's complete lines into records_ and done_steps_; returns their length in bytes.
  Result<size_t> ReadJournal(const std::string& journal);
  Status ReadJournalLine(const std::string& line);
  Status CheckKeyAgainstPlan(const FrameKey& key) const;
  Status AppendToJournal(const nlohmann::json& record);

  std::filesystem::path directory_;
  std::shared_ptr<void> writer_lock_;  // while this store writes (empty when read-only)
  ScanInfo info_;
  std::vector<FrameRecord> records_;
  std::set<int> done_steps_;
  std::string chain_;     // the last line's chain link ("" before the first)
  bool chained_ = false;  // a chained line has been read or written: every later one must be
  bool torn_last_line_ = false;
};

std::string FrameChecksum(const std::vector<uint16_t>& pixels);

// A scan checked as `loom scan --verify` does, changing nothing: the journal read as Open reads it
// (a broken chain or an impossible record is the returned error), then every recorded frame
// read back against its checksum.
struct ScanIntegrity {
  int frames = 0;                           // recorded in the journal
  int frames_verified = 0;                  // read back, matching their records
  std::vector<Status> damaged;              // the others, each naming its file
  int steps_done = 0;                       // of
  int steps_planned = 0;                    //
  bool torn_last_line = false;              // a crash mid-append: a resume drops it
  std::vector<std::string> partial_frames;  // in frames/ without a record: a resume redoes them
  std::vector<std::string> foreign_files;   // in frames/ and not the store's: a resume leaves them

  bool intact() const { return damaged.empty(); }
  bool complete() const { return steps_done == steps_planned; }
  void Report(std::ostream& out) const;
};
Result<ScanIntegrity> VerifyScan(const std::filesystem::path& directory);

}  // namespace loom::scan
