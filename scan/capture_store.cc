#include "scan/capture_store.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "core/config.h"
#include "core/exr_io.h"
#include "core/file_io.h"
#include "core/log.h"
#include "core/version.h"

namespace loom::scan {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr int kScanSchemaVersion = 1;
constexpr char kPixelChannel[] = "DN";
constexpr char kPlanFile[] = "plan.yaml";
constexpr char kWriterLockFile[] = "writer.lock";

// An exclusive flock on `directory`/writer.lock for as long as the returned handle lives. The
// kernel drops it when the process dies, so a killed scan never leaves its directory locked;
// the holder's pid is written into the file for the message a second writer gets.
Result<std::shared_ptr<void>> LockForWriting(const fs::path& directory, const fs::path& shown_as) {
  const fs::path path = directory / kWriterLockFile;
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return IoError(path.string(), std::string("cannot open the writer lock: ") + std::strerror(errno));
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    char holder[32] = {};
    const ssize_t read = ::pread(fd, holder, sizeof(holder) - 1, 0);
    ::close(fd);
    if (error != EWOULDBLOCK) return IoError(path.string(), std::string("cannot lock: ") + std::strerror(error));
    const std::string pid = read > 0 ? " (pid " + std::string(holder, static_cast<size_t>(read)) + ")" : "";
    return FailedPreconditionError(shown_as.string(), "is being written by another process" + pid +
                                                          ": one writer per scan; let it finish or stop it, then resume");
  }
  // The pid only makes the message clearer: a full disk must not stop a resume here.
  const std::string pid = std::to_string(::getpid());
  if (::ftruncate(fd, 0) == 0 && ::pwrite(fd, pid.data(), pid.size(), 0) < 0) {
    LOOM_LOG(Warning) << path.string() << ": could not record this process's pid (" << std::strerror(errno) << ")";
  }
  return std::shared_ptr<void>(nullptr, [fd](void*) { ::close(fd); });
}

// Whether `name` (a file in frames/) is one the store writes: a frame, or a frame's temporary
// (core's atomic writes: ".<name>.tmp-<pid>"). Resume deletes only these.
bool IsStoreFrameName(const std::string& name) {
  static const std::regex frame(R"(\.?s\d{5}_[^/]+_e\d{2}\.exr(\.tmp-\d+)?)");
  return std::regex_match(name, frame);
}

std::string FrameFileName(const FrameKey& key) {
  char name[160];
  std::snprintf(name, sizeof(name), "frames/s%05d_%s_e%02d.exr", key.step, key.camera.c_str(), key.exposure);
  return name;
}

// The journal is a hash chain: every line ends in "chain", the FNV-1a 64 of the previous line's
// chain and this line's record, so an edited, inserted, removed or reordered line breaks the
// chain at that line. (Not a defence against someone who recomputes it: against slips, tools
// and bit rot.) Lines of scans from before the chain have none, and stay readable.
constexpr std::string_view kChainKey = R"(,"chain":")";
constexpr size_t kChainHexDigits = 16;

std::string ChainAfter(const std::string& previous, std::string_view record) {
  uint64_t hash = 0xcbf29ce484222325ull;
  for (std::string_view part : {std::string_view(previous), record}) {
    for (unsigned char byte : part) {
      hash ^= byte;
      hash *= 0x100000001b3ull;
    }
  }
  char text[kChainHexDigits + 1];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(hash));
  return text;
}

// `record` (a JSON object's text) with its chain link appended as the object's last member.
std::string ChainedLine(const std::string& record, const std::string& chain) {
  return record.substr(0, record.size() - 1) + std::string(kChainKey) + chain + "\"}";
}

// A line's record text and its chain link (empty for a line from before the chain).
std::pair<std::string, std::string> SplitChain(const std::string& line) {
  const size_t at = line.rfind(kChainKey);
  if (at == std::string::npos || line.size() != at + kChainKey.size() + kChainHexDigits + 2 || !line.ends_with("\"}")) {
    return {line, ""};
  }
  return {line.substr(0, at) + "}", line.substr(at + kChainKey.size(), kChainHexDigits)};
}

Json ToJson(const FrameRecord& r) {
  const FrameMetadata& m = r.metadata;
  Json leds = Json::array();
  for (const LedDrive& led : m.rig_state.leds_on) leds.push_back({led.led, led.current_ma});
  return {{"step", r.key.step},
          {"camera", r.key.camera},
          {"exposure", r.key.exposure},
          {"file", r.file},
          {"checksum", r.checksum},
          {"width", r.width},
          {"height", r.height},
          {"roi", {m.roi.x, m.roi.y, m.roi.width, m.roi.height}},
          {"serial", m.camera_serial},
          {"pixel_format", std::string(PixelFormatName(m.pixel_format))},
          {"exposure_us", m.exposure_us},
          {"gain", m.gain},
          {"frame_id", m.frame_id},
          {"device_timestamp_ns", m.device_timestamp_ns},
          {"host_timestamp_ns", m.host_timestamp_ns},
          {"rig",
           {{"leds", leds},
            {"filter_slots", m.rig_state.filter_slots},
            {"turntable_deg", m.rig_state.turntable_deg},
            {"linear_light_mm", m.rig_state.linear_light_mm},
            {"linear_light_on", m.rig_state.linear_light_on},
            {"linear_light_intensity", m.rig_state.linear_light_intensity},
            {"projector_pattern", m.rig_state.projector_pattern},
            {"settled_ms", m.rig_state.settled_ms}}}};
}

FrameRecord FromJson(const Json& j) {
  FrameRecord r;
  r.key = {j.at("step").get<int>(), j.at("camera").get<std::string>(), j.at("exposure").get<int>()};
  r.file = j.at("file").get<std::string>();
  r.checksum = j.at("checksum").get<std::string>();
  r.width = j.at("width").get<int>();
  r.height = j.at("height").get<int>();
  FrameMetadata& m = r.metadata;
  m.camera = r.key.camera;
  if (j.contains("roi")) {  // journals written before regions of interest were kept have none: the whole sensor
    const auto roi = j.at("roi").get<std::array<int, 4>>();
    m.roi = {roi[0], roi[1], roi[2], roi[3]};
  }
  m.camera_serial = j.at("serial").get<std::string>();
  m.pixel_format = ParsePixelFormat(j.at("pixel_format").get<std::string>()).value();
  m.exposure_us = j.at("exposure_us").get<double>();
  m.gain = j.at("gain").get<double>();
  m.frame_id = j.at("frame_id").get<uint64_t>();
  m.device_timestamp_ns = j.at("device_timestamp_ns").get<uint64_t>();
  m.host_timestamp_ns = j.at("host_timestamp_ns").get<int64_t>();
  const Json& rig = j.at("rig");
  for (const Json& led : rig.at("leds")) m.rig_state.leds_on.push_back({led.at(0).get<int>(), led.at(1).get<double>()});
  m.rig_state.filter_slots = rig.at("filter_slots").get<std::map<std::string, int>>();
  m.rig_state.turntable_deg = rig.at("turntable_deg").get<double>();
  m.rig_state.linear_light_mm = rig.at("linear_light_mm").get<double>();
  m.rig_state.linear_light_on = rig.at("linear_light_on").get<bool>();
  m.rig_state.linear_light_intensity = rig.at("linear_light_intensity").get<double>();
  m.rig_state.projector_pattern = rig.at("projector_pattern").get<std::string>();
  // Journals written before settle times were kept have none.
  if (rig.contains("settled_ms")) m.rig_state.settled_ms = rig.at("settled_ms").get<double>();
  return r;
}

// FNV-1a over the bytes, as the frames' checksums are: plan.yaml's, kept in scan.yaml so that a
// plan edited after the capture is found (its steps describe what the frames were taken under).
std::string TextChecksum(std::string_view text) {
  uint64_t hash = 0xcbf29ce484222325ull;
  for (const char c : text) {
    hash ^= static_cast<unsigned char>(c);
    hash *= 0x100000001b3ull;
  }
  char hex[17];
  std::snprintf(hex, sizeof(hex), "%016llx", static_cast<unsigned long long>(hash));
  return hex;
}

std::string ScanYaml(const ScanInfo& info) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "schema_version" << YAML::Value << kScanSchemaVersion;
  out << YAML::Key << "loom_version" << YAML::Value << std::string(VersionWithCommit());
  out << YAML::Key << "object" << YAML::Value << info.object;
  if (info.crop_mm > 0) out << YAML::Key << "crop_mm" << YAML::Value << info.crop_mm;
  out << YAML::Key << "plan" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "purpose" << YAML::Value << std::string(PlanPurposeName(info.plan.purpose));
  out << YAML::Key << "preset" << YAML::Value << info.plan.preset;
  out << YAML::Key << "steps" << YAML::Value << info.plan.steps.size();
  out << YAML::Key << "file" << YAML::Value << kPlanFile;
  out << YAML::Key << "checksum" << YAML::Value << TextChecksum(PlanToYaml(info.plan));
  out << YAML::EndMap;
  out << YAML::Key << "rig" << YAML::Value << YAML::Literal << info.rig_yaml;
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

Result<ScanInfo> ReadScanYaml(const fs::path& directory) {
  const fs::path path = directory / "scan.yaml";
  LOOM_ASSIGN_OR_RETURN(const ConfigDocument doc, ConfigDocument::LoadFile(path, kScanSchemaVersion));
  ScanInfo info;
  std::string version, purpose, preset, plan_file, plan_checksum;
  int steps = 0;
  doc.root().Required("loom_version", &version);
  doc.root().Required("object", &info.object);
  doc.root().Optional("crop_mm", &info.crop_mm);
  doc.root().Required("rig", &info.rig_yaml);
  const ConfigNode plan = doc.root().Child("plan");
  plan.Required("purpose", &purpose);
  plan.Required("preset", &preset);
  plan.Required("steps", &steps);
  plan.Required("file", &plan_file);
  plan.Optional("checksum", &plan_checksum);  // scans made before it was kept have none
  LOOM_RETURN_IF_ERROR(doc.Finish());
  if (!(info.crop_mm >= 0) || !std::isfinite(info.crop_mm)) return InvalidArgumentError(path.string(), "crop_mm must be ≥ 0");
  const fs::path plan_path = directory / plan_file;
  LOOM_ASSIGN_OR_RETURN(const std::string plan_text, ReadFile(plan_path));
  LOOM_ASSIGN_OR_RETURN(info.plan, ParsePlanYaml(plan_text, plan_path.string()));  // a broken plan: its own error
  if (!plan_checksum.empty() && TextChecksum(plan_text) != plan_checksum) {
    return DataLossError(plan_path.string(), "was changed after the scan was made (checksum " + TextChecksum(plan_text) + ", " +
                                                 path.string() + " says " + plan_checksum +
                                                 "): its steps say what the frames were captured under; restore it");
  }
  if (static_cast<int>(info.plan.steps.size()) != steps || PlanPurposeName(info.plan.purpose) != purpose ||
      info.plan.preset != preset) {
    return DataLossError(plan_path.string(), "does not match " + path.string() + " (" + std::to_string(steps) + " steps of a " +
                                                 purpose + " scan with preset '" + preset + "')");
  }
  return info;
}

}  // namespace

std::string FrameChecksum(const std::vector<uint16_t>& pixels) {
  uint64_t hash = 0xcbf29ce484222325ull;
  for (uint16_t value : pixels) {
    for (int byte = 0; byte < 2; ++byte) {
      hash ^= (value >> (8 * byte)) & 0xFF;
      hash *= 0x100000001b3ull;
    }
  }
  char text[17];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(hash));
  return text;
}

Result<CaptureStore> CaptureStore::Create(const fs::path& directory, const ScanInfo& info) {
  std::error_code ec;
  LOOM_RETURN_IF_ERROR(CheckDirectoryOutputPath(directory, "scan folder"));
  if (fs::exists(directory, ec) && !fs::is_directory(directory, ec)) {
    return AlreadyExistsError(directory.string(), "exists and is not a directory: a scan never replaces a file");
  }
  if (fs::exists(directory, ec) && !fs::is_empty(directory, ec)) {
    return AlreadyExistsError(directory.string(), "not empty: a scan is never written over (use --resume to continue it)");
  }
  // Built under a temporary name and renamed: a scan directory always has its scan.yaml, so a
  // crash here leaves either nothing or a scan that can be resumed.
  const fs::path parent = directory.parent_path().empty() ? fs::path(".") : directory.parent_path();
  const fs::path building = parent / ("." + directory.filename().string() + ".creating-" + std::to_string(::getpid()));
  fs::remove_all(building, ec);
  fs::create_directories(building / "frames", ec);
  if (ec) return IoError(directory.string(), "cannot create: " + ec.message());
  // Locked before it has its name: the lock file's inode goes with the rename.
  Result<std::shared_ptr<void>> lock = LockForWriting(building, directory);
  if (!lock.ok()) {
    fs::remove_all(building, ec);
    return lock.status();
  }
  for (const auto& [file, text] : {std::pair{kPlanFile, PlanToYaml(info.plan)}, std::pair{"scan.yaml", ScanYaml(info)}}) {
    if (Status written = WriteFileAtomically(building / file, text); !written.ok()) {
      fs::remove_all(building, ec);
      return written;
    }
  }
  fs::remove(directory, ec);  // empty, if it exists
  fs::rename(building, directory, ec);
  if (ec) {
    fs::remove_all(building, ec);
    return IoError(directory.string(), "cannot create: " + ec.message());
  }
  CaptureStore store(directory);
  store.writer_lock_ = *std::move(lock);
  store.info_ = info;
  return store;
}

Result<CaptureStore> CaptureStore::Open(const fs::path& directory, bool repair) {
  std::error_code ec;
  if (!fs::exists(directory / "scan.yaml", ec)) {
    return NotFoundError(directory.string(), "not a scan directory (no scan.yaml): nothing to read or resume");
  }
  CaptureStore store(directory);
  if (repair) {
    LOOM_ASSIGN_OR_RETURN(store.writer_lock_, LockForWriting(directory, directory));
  }
  LOOM_ASSIGN_OR_RETURN(store.info_, ReadScanYaml(directory));
  std::string journal;
  if (fs::exists(store.JournalPath())) {
    LOOM_ASSIGN_OR_RETURN(journal, ReadFile(store.JournalPath()));
  }
  LOOM_ASSIGN_OR_RETURN(const size_t good_bytes, store.ReadJournal(journal));
  if (repair) {
    if (good_bytes < journal.size()) {
      fs::resize_file(store.JournalPath(), good_bytes);
    }
    // Frames without a record never completed: remove them, and any temporary files. A file
    // the store would never have written is someone else's: it stays.
    const UnrecordedFiles unrecorded = store.Unrecorded();
    std::error_code ec;
    for (const fs::path& partial : unrecorded.partial) fs::remove(partial, ec);
    for (const fs::path& foreign : unrecorded.foreign) {
      LOOM_LOG(Warning) << foreign.string() << ": not a file this scan wrote; left as it is";
    }
  } else {
    store.torn_last_line_ = good_bytes < journal.size();
  }
  return store;
}

CaptureStore::UnrecordedFiles CaptureStore::Unrecorded() const {
  std::set<std::string> recorded;
  for (const FrameRecord& record : records_) recorded.insert(record.file);
  UnrecordedFiles unrecorded;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(directory_ / "frames", ec)) {
    const std::string name = entry.path().filename().string();
    if (recorded.contains("frames/" + name)) continue;
    (IsStoreFrameName(name) ? unrecorded.partial : unrecorded.foreign).push_back(entry.path());
  }
  std::sort(unrecorded.partial.begin(), unrecorded.partial.end());
  std::sort(unrecorded.foreign.begin(), unrecorded.foreign.end());
  return unrecorded;
}

Result<size_t> CaptureStore::ReadJournal(const std::string& journal) {
  size_t good_bytes = 0;
  int line_number = 0;
  for (size_t begin = 0; begin < journal.size();) {
    ++line_number;
    const size_t end = journal.find('\n', begin);
    if (end == std::string::npos) break;  // torn: the last append never completed
    if (const Status read = ReadJournalLine(journal.substr(begin, end - begin)); !read.ok()) {
      return DataLossError(JournalPath().string() + ", line " + std::to_string(line_number), read.message());
    }
    good_bytes = end + 1;
    begin = end + 1;
  }
  return good_bytes;
}

Status CaptureStore::ReadJournalLine(const std::string& line) {
  const auto [record_text, link] = SplitChain(line);
  if (link.empty() && chained_) return DataLossError("journal", "has lost its chain link here: the line was edited");
  if (!link.empty() && link != ChainAfter(chain_, record_text)) {
    return DataLossError("journal", "breaks its hash chain here: a line was edited, inserted, removed or reordered");
  }
  chained_ = chained_ || !link.empty();
  chain_ = link.empty() ? ChainAfter(chain_, line) : link;
  Json json;
  FrameRecord record;
  try {
    json = Json::parse(record_text);
    if (!json.contains("step_done")) record = FromJson(json);
  } catch (const std::exception& e) {
    return DataLossError("journal", std::string("is corrupt (") + e.what() + ")");
  }
  if (json.contains("step_done")) {
    const int step = json.at("step_done").is_number_integer() ? json.at("step_done").get<int>() : -1;
    if (step < 0 || step >= static_cast<int>(info_.plan.steps.size())) {
      return DataLossError("journal", "marks done a step the plan does not have (" + json.at("step_done").dump() + ")");
    }
    if (!done_steps_.insert(step).second) return DataLossError("journal", "marks step " + std::to_string(step) + " done twice");
    return Status::Ok();
  }
  LOOM_RETURN_IF_ERROR(CheckKeyAgainstPlan(record.key));
  if (record.file != FrameFileName(record.key)) {
    return DataLossError("journal", "names the frame's file '" + record.file + "', not " + FrameFileName(record.key));
  }
  if (Has(record.key)) return DataLossError("journal", "records " + record.file + " a second time");
  records_.push_back(std::move(record));
  return Status::Ok();
}

// A frame the sequencer could have taken: a step of the plan, one of its cameras, an exposure
// within its bracket.
Status CaptureStore::CheckKeyAgainstPlan(const FrameKey& key) const {
  const std::vector<Step>& steps = info_.plan.steps;
  if (key.step < 0 || key.step >= static_cast<int>(steps.size())) {
    return DataLossError("journal", "records a frame of step " + std::to_string(key.step) + ", which the plan (" +
                                        std::to_string(steps.size()) + " steps) does not have");
  }
  const Step& step = steps[static_cast<size_t>(key.step)];
  if (std::find(step.cameras.begin(), step.cameras.end(), key.camera) == step.cameras.end()) {
    return DataLossError(
        "journal", "records a frame of camera '" + key.camera + "', which step " + std::to_string(key.step) + " does not use");
  }
  if (key.exposure < 0 || key.exposure >= step.exposure.max_exposures + step.exposure.linearity_series) {
    return DataLossError("journal", "records exposure " + std::to_string(key.exposure) + " of step " + std::to_string(key.step) +
                                        ", beyond its bracket");
  }
  return Status::Ok();
}

Status CaptureStore::AppendToJournal(const nlohmann::json& record) {
  const std::string text = record.dump();
  const std::string chain = ChainAfter(chain_, text);
  LOOM_RETURN_IF_ERROR(AppendLineDurably(JournalPath(), ChainedLine(text, chain)));
  chain_ = chain;
  chained_ = true;
  return Status::Ok();
}

bool CaptureStore::Has(const FrameKey& key) const {
  for (const FrameRecord& record : records_) {
    if (record.key == key) return true;
  }
  return false;
}

Status CaptureStore::Append(const FrameKey& key, const RawFrame& frame) {
  if (Has(key)) {
    return AlreadyExistsError(directory_.string(), "frame " + FrameFileName(key) + " is already stored");
  }
  if (const Status possible = CheckKeyAgainstPlan(key); !possible.ok()) {
    return InvalidArgumentError(directory_.string(), "frame " + FrameFileName(key) + ": " + possible.message());
  }
  FrameRecord record;
  record.key = key;
  record.file = FrameFileName(key);
  record.checksum = FrameChecksum(frame.pixels);
  record.width = frame.width;
  record.height = frame.height;
  record.metadata = frame.metadata;
  LOOM_RETURN_IF_ERROR(WriteExrUint16(directory_ / record.file, frame.width, frame.height, frame.pixels, kPixelChannel,
                                      {{"loom.camera", key.camera}, {"loom.step", key.step}}));
  LOOM_RETURN_IF_ERROR(AppendToJournal(ToJson(record)));
  records_.push_back(std::move(record));
  return Status::Ok();
}

Status CaptureStore::MarkStepDone(int step) {
  LOOM_RETURN_IF_ERROR(AppendToJournal(Json{{"step_done", step}}));
  done_steps_.insert(step);
  return Status::Ok();
}

Result<RawFrame> CaptureStore::ReadFrame(const FrameRecord& record) const {
  const fs::path path = directory_ / record.file;
  LOOM_ASSIGN_OR_RETURN(ExrUint16Image image, ReadExrUint16(path, kPixelChannel));
  if (image.width != record.width || image.height != record.height) {
    return DataLossError(path.string(), "is " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                                            ", the journal says " + std::to_string(record.width) + "x" +
                                            std::to_string(record.height));
  }
  const std::string checksum = FrameChecksum(image.pixels);
  if (checksum != record.checksum) {
    return DataLossError(path.string(), "checksum mismatch (" + checksum + ", journal " + record.checksum +
                                            "): the frame was altered after it was stored");
  }
  RawFrame frame;
  frame.width = image.width;
  frame.height = image.height;
  frame.pixels = std::move(image.pixels);
  frame.metadata = record.metadata;
  return frame;
}

Result<ScanIntegrity> VerifyScan(const fs::path& directory) {
  LOOM_ASSIGN_OR_RETURN(const CaptureStore store, CaptureStore::Open(directory));
  ScanIntegrity integrity;
  integrity.frames = static_cast<int>(store.records().size());
  integrity.steps_done = store.steps_done();
  integrity.steps_planned = static_cast<int>(store.info().plan.steps.size());
  for (const FrameRecord& record : store.records()) {
    if (Result<RawFrame> frame = store.ReadFrame(record); frame.ok()) {
      ++integrity.frames_verified;
    } else {
      integrity.damaged.push_back(frame.status());
    }
  }
  integrity.torn_last_line = store.torn_last_line();
  const CaptureStore::UnrecordedFiles unrecorded = store.Unrecorded();
  for (const fs::path& file : unrecorded.partial) integrity.partial_frames.push_back(file.string());
  for (const fs::path& file : unrecorded.foreign) integrity.foreign_files.push_back(file.string());
  return integrity;
}

void ScanIntegrity::Report(std::ostream& out) const {
  out << frames_verified << " of " << frames << " recorded frames verified against their checksums; " << steps_done << " of "
      << steps_planned << " steps done" << (complete() ? "" : " (incomplete: loom scan --resume continues it)") << "\n";
  for (const Status& frame : damaged) out << "  DAMAGED " << frame.ToString() << "\n";
  if (torn_last_line) out << "  the journal's last line is torn (a crash mid-append): a resume drops it\n";
  for (const std::string& file : partial_frames) out << "  partial (no record; a resume redoes it): " << file << "\n";
  for (const std::string& file : foreign_files) out << "  not written by the scan (left as it is): " << file << "\n";
  out << (intact() ? "intact" : "DAMAGED: the frames above no longer hold what was captured") << "\n";
}

}  // namespace loom::scan
