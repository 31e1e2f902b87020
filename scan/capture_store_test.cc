#include "scan/capture_store.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <fstream>
#include <sstream>

#include "core/exr_io.h"
#include "core/file_io.h"

namespace loom::scan {
namespace {

namespace fs = std::filesystem;

RawFrame Frame(int seed) {
  RawFrame frame;
  frame.width = 16;
  frame.height = 12;
  for (int i = 0; i < 16 * 12; ++i) frame.pixels.push_back(static_cast<uint16_t>((i * 37 + seed * 1001) % 4096));
  frame.metadata.camera = "cam0";
  frame.metadata.camera_serial = "SIM-cam0";
  frame.metadata.pixel_format = PixelFormat::kMono12;
  frame.metadata.exposure_us = 1250.5;
  frame.metadata.frame_id = 7 + seed;
  frame.metadata.rig_state.leds_on = {{3, 800}};
  frame.metadata.rig_state.filter_slots = {{"wheel0", 2}};
  frame.metadata.rig_state.turntable_deg = 120;
  return frame;
}

Plan TwoStepPlan() {
  Plan plan{"r", "low", PlanPurpose::kMaterial, {}};
  plan.steps.resize(2);
  plan.steps[1].index = 1;
  plan.steps[1].leds = {{3, 800}};
  plan.steps[1].linear_light_mm = 1.0 / 3;
  for (Step& step : plan.steps) step.cameras = {"cam0"};
  return plan;
}

class CaptureStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("store_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  CaptureStore MakeStore() {
    Result<CaptureStore> store = CaptureStore::Create(dir_, {"schema_version: 1\nname: r\n", "fabric 3", TwoStepPlan()});
    EXPECT_TRUE(store.ok()) << store.status().ToString();
    return std::move(*store);
  }

  fs::path dir_;
};

TEST_F(CaptureStoreTest, FramesAndWhatTheDevicesDidRoundTrip) {
  CaptureStore store = MakeStore();
  ASSERT_TRUE(store.Append({0, "cam0", 0}, Frame(0)).ok());
  ASSERT_TRUE(store.Append({0, "cam0", 1}, Frame(1)).ok());
  EXPECT_EQ(store.Append({0, "cam0", 1}, Frame(1)).code(), StatusCode::kAlreadyExists);

  const Result<CaptureStore> reopened = CaptureStore::Open(dir_);
  ASSERT_TRUE(reopened.ok()) << reopened.status().ToString();
  EXPECT_EQ(reopened->info().object, "fabric 3");
  EXPECT_EQ(reopened->info().rig_yaml, "schema_version: 1\nname: r\n");
  EXPECT_EQ(reopened->info().plan, TwoStepPlan());
  ASSERT_EQ(reopened->records().size(), 2u);
  const Result<RawFrame> frame = reopened->ReadFrame(reopened->records()[1]);
  ASSERT_TRUE(frame.ok()) << frame.status().ToString();
  EXPECT_EQ(frame->pixels, Frame(1).pixels);
  EXPECT_EQ(frame->metadata.exposure_us, 1250.5);
  EXPECT_EQ(frame->metadata.rig_state, Frame(1).metadata.rig_state);
  EXPECT_TRUE(reopened->Has({0, "cam0", 0}));
  EXPECT_FALSE(reopened->Has({1, "cam0", 0}));
}

TEST(FrameTest, AFrameForAPersonIsItsCountsAsFloatsWithItsMetadata) {
  RawFrame frame;
  frame.width = 3;
  frame.height = 2;
  frame.pixels = {0, 1, 2, 4095, 4096, 65535};
  frame.metadata.camera = "cam1";
  frame.metadata.camera_serial = "SN7";
  frame.metadata.exposure_us = 1250;
  frame.metadata.rig_state.turntable_deg = 120;
  frame.metadata.rig_state.leds_on = {{3, 1000}, {4, 500}};
  const std::filesystem::path path = std::filesystem::path(::testing::TempDir()) / "frame_test.exr";
  ASSERT_TRUE(WriteFrameExr(frame, path).ok());
  const Result<ExrImage> read = ReadExr(path);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(read->image.channel_names(), std::vector<std::string>{"Y"});
  EXPECT_EQ(read->image.at(0, 1, 2), 65535.0f);
  EXPECT_EQ(std::get<std::string>(read->attributes.at("loom.cameraSerial")), "SN7");
  EXPECT_EQ(std::get<double>(read->attributes.at("loom.exposure_us")), 1250);
  EXPECT_EQ(std::get<double>(read->attributes.at("loom.turntable_deg")), 120);
  EXPECT_EQ(std::get<int>(read->attributes.at("loom.ledsOn")), 2);
  std::filesystem::remove(path);
}

TEST_F(CaptureStoreTest, AlteredTruncatedAndMissingFramesAreNamed) {
  CaptureStore store = MakeStore();
  for (int e = 0; e < 3; ++e) ASSERT_TRUE(store.Append({0, "cam0", e}, Frame(e)).ok());
  const auto& records = store.records();
  // Altered: a valid frame file with other pixels.
  const fs::path altered = dir_ / records[0].file;
  ASSERT_TRUE(WriteExrUint16(altered, 16, 12, Frame(9).pixels, "DN").ok());
  const Result<RawFrame> bad = store.ReadFrame(records[0]);
  EXPECT_EQ(bad.status().code(), StatusCode::kDataLoss);
  EXPECT_EQ(bad.status().subject(), altered.string());
  EXPECT_NE(bad.status().message().find("checksum mismatch"), std::string::npos);
  // Truncated.
  const fs::path truncated = dir_ / records[1].file;
  fs::resize_file(truncated, fs::file_size(truncated) / 2);
  EXPECT_EQ(store.ReadFrame(records[1]).status().code(), StatusCode::kDataLoss);
  // Missing.
  fs::remove(dir_ / records[2].file);
  const Result<RawFrame> missing = store.ReadFrame(records[2]);
  EXPECT_EQ(missing.status().code(), StatusCode::kNotFound);
  EXPECT_EQ(missing.status().subject(), (dir_ / records[2].file).string());
}

TEST_F(CaptureStoreTest, ACrashMidAppendIsRepairedOnResume) {
  {
    CaptureStore store = MakeStore();  // the process that crashes: its writer lock goes with it
    ASSERT_TRUE(store.Append({0, "cam0", 0}, Frame(0)).ok());
    ASSERT_TRUE(store.Append({0, "cam0", 1}, Frame(1)).ok());
  }
  // A crash after the frame of step 1 but mid-way through its journal record, plus a leftover
  // temporary file and a frame that never got a record.
  const std::string journal = *ReadFile(dir_ / "journal.jsonl");
  std::ofstream(dir_ / "journal.jsonl", std::ios::app) << journal.substr(0, 40);
  std::ofstream(dir_ / "frames" / ".s00001_cam0_e00.exr.tmp-123") << "partial";
  ASSERT_TRUE(WriteExrUint16(dir_ / "frames" / "s00001_cam0_e00.exr", 16, 12, Frame(2).pixels, "DN").ok());
  // And files the store never writes, which resuming must not touch.
  std::ofstream(dir_ / "frames" / "notes.txt") << "the operator's";
  std::ofstream(dir_ / "frames" / "s00001_cam0_e00.exr.bak") << "a copy";

  // Reading tolerates the torn line; resuming removes it and the partial files.
  ASSERT_EQ(CaptureStore::Open(dir_)->records().size(), 2u);
  Result<CaptureStore> resumed = CaptureStore::Open(dir_, /*repair=*/true);
  ASSERT_TRUE(resumed.ok()) << resumed.status().ToString();
  EXPECT_FALSE(resumed->Has({1, "cam0", 0}));
  EXPECT_FALSE(fs::exists(dir_ / "frames" / "s00001_cam0_e00.exr"));
  EXPECT_FALSE(fs::exists(dir_ / "frames" / ".s00001_cam0_e00.exr.tmp-123"));
  EXPECT_TRUE(fs::exists(dir_ / "frames" / "notes.txt"));
  EXPECT_TRUE(fs::exists(dir_ / "frames" / "s00001_cam0_e00.exr.bak"));
  ASSERT_TRUE(resumed->Append({1, "cam0", 0}, Frame(2)).ok());
  const Result<CaptureStore> after = CaptureStore::Open(dir_);
  ASSERT_TRUE(after.ok()) << after.status().ToString();
  EXPECT_EQ(after->records().size(), 3u);
  for (const FrameRecord& record : after->records()) EXPECT_TRUE(after->ReadFrame(record).ok()) << record.file;
}

// A crash can tear the journal's last append after any byte. At every position the torn record
// is dropped with its frame, the records before it stay, and capturing the frame again leaves
// each frame exactly once with the pixels it had: none lost, none twice.
TEST_F(CaptureStoreTest, AJournalTornAtEveryBytePositionLosesAndDuplicatesNothing) {
  const FrameKey kept{0, "cam0", 0};
  const FrameKey torn{1, "cam0", 0};
  std::string last_record;
  std::string journal_before;
  {
    CaptureStore store = MakeStore();
    ASSERT_TRUE(store.Append(kept, Frame(0)).ok());
    journal_before = *ReadFile(dir_ / "journal.jsonl");
    ASSERT_TRUE(store.Append(torn, Frame(1)).ok());
    last_record = ReadFile(dir_ / "journal.jsonl")->substr(journal_before.size());
  }
  const fs::path torn_frame = dir_ / "frames" / "s00001_cam0_e00.exr";
  const fs::path saved_frame = dir_ / "saved.exr";
  fs::copy_file(torn_frame, saved_frame);
  ASSERT_GT(last_record.size(), 100u);
  ASSERT_EQ(last_record.back(), '\n');

  for (size_t bytes = 0; bytes < last_record.size(); ++bytes) {
    SCOPED_TRACE("torn after " + std::to_string(bytes) + " bytes of the last record");
    ASSERT_TRUE(WriteFileAtomically(dir_ / "journal.jsonl", journal_before + last_record.substr(0, bytes)).ok());
    fs::copy_file(saved_frame, torn_frame, fs::copy_options::overwrite_existing);
    {
      Result<CaptureStore> resumed = CaptureStore::Open(dir_, /*repair=*/true);
      ASSERT_TRUE(resumed.ok()) << resumed.status().ToString();
      ASSERT_EQ(resumed->records().size(), 1u);
      EXPECT_TRUE(resumed->Has(kept));
      EXPECT_FALSE(fs::exists(torn_frame));
      ASSERT_TRUE(resumed->Append(torn, Frame(1)).ok());
    }
    const Result<CaptureStore> after = CaptureStore::Open(dir_);
    ASSERT_TRUE(after.ok()) << after.status().ToString();
    ASSERT_EQ(after->records().size(), 2u);
    EXPECT_EQ(*ReadFile(dir_ / "journal.jsonl"), journal_before + last_record);
    for (int i = 0; i < 2; ++i) {
      const Result<RawFrame> frame = after->ReadFrame(after->records()[i]);
      ASSERT_TRUE(frame.ok()) << frame.status().ToString();
      EXPECT_EQ(frame->pixels, Frame(i).pixels);
    }
  }
}

TEST_F(CaptureStoreTest, APlanFileThatDisagreesWithScanYamlIsAnError) {
  MakeStore();
  Plan other = TwoStepPlan();
  other.steps.pop_back();
  ASSERT_TRUE(WriteFileAtomically(dir_ / "plan.yaml", PlanToYaml(other)).ok());
  const Result<CaptureStore> opened = CaptureStore::Open(dir_);
  ASSERT_FALSE(opened.ok());
  EXPECT_EQ(opened.status().code(), StatusCode::kDataLoss);
  EXPECT_NE(opened.status().subject().find("plan.yaml"), std::string::npos) << opened.status().ToString();
}

TEST_F(CaptureStoreTest, CorruptJournalAndExistingScanAreErrors) {
  CaptureStore store = MakeStore();
  ASSERT_TRUE(store.Append({0, "cam0", 0}, Frame(0)).ok());
  ASSERT_TRUE(store.Append({1, "cam0", 0}, Frame(1)).ok());
  std::string journal = *ReadFile(dir_ / "journal.jsonl");
  journal[5] = '#';  // inside the first record, not the last line
  ASSERT_TRUE(WriteFileAtomically(dir_ / "journal.jsonl", journal).ok());
  const Result<CaptureStore> opened = CaptureStore::Open(dir_);
  ASSERT_FALSE(opened.ok());
  EXPECT_EQ(opened.status().code(), StatusCode::kDataLoss);
  EXPECT_NE(opened.status().ToString().find("journal.jsonl, line 1: breaks its hash chain"), std::string::npos)
      << opened.status().ToString();
  const Result<CaptureStore> again = CaptureStore::Create(dir_, {});
  EXPECT_EQ(again.status().code(), StatusCode::kAlreadyExists);
  // An existing file, even an empty one, is never replaced by a scan.
  std::ofstream(dir_.string() + ".txt").close();
  const Result<CaptureStore> over_file = CaptureStore::Create(dir_.string() + ".txt", {});
  EXPECT_EQ(over_file.status().code(), StatusCode::kAlreadyExists);
  EXPECT_NE(over_file.status().message().find("not a directory"), std::string::npos) << over_file.status().ToString();
  EXPECT_TRUE(fs::is_regular_file(dir_.string() + ".txt"));
  fs::remove(dir_.string() + ".txt");
  const Result<CaptureStore> nothing = CaptureStore::Open(dir_ / "nowhere");
  EXPECT_EQ(nothing.status().code(), StatusCode::kNotFound);
  EXPECT_NE(nothing.status().message().find("not a scan directory"), std::string::npos);
}

// The journal's lines without their chain links, as a scan from before the chain has them.
std::vector<std::string> UnchainedLines(const std::string& journal) {
  std::vector<std::string> lines;
  std::istringstream in(journal);
  for (std::string line; std::getline(in, line);) {
    const size_t link = line.rfind(R"(,"chain":")");
    lines.push_back(link == std::string::npos ? line : line.substr(0, link) + "}");
  }
  return lines;
}

std::string Joined(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& line : lines) text += line + "\n";
  return text;
}

// A one-character edit of an exposure once gave 1,024 values off by up to 99 % with reconstruct
// exit 0: the journal's hash chain now refuses any edited, removed or reordered line, and a
// record that is a duplicate or that the plan cannot have made is refused even in an old scan's
// unchained journal. Every refusal names the journal and the line.
TEST_F(CaptureStoreTest, EditedDuplicatedAndImpossibleJournalLinesAreRefusedNamingTheLine) {
  {
    CaptureStore store = MakeStore();
    for (int e = 0; e < 3; ++e) ASSERT_TRUE(store.Append({0, "cam0", e}, Frame(e)).ok());
    ASSERT_TRUE(store.MarkStepDone(0).ok());
    const Status impossible = store.Append({5, "cam0", 0}, Frame(5));  // the plan has 2 steps
    EXPECT_EQ(impossible.code(), StatusCode::kInvalidArgument) << impossible.ToString();
    EXPECT_FALSE(store.Append({1, "cam9", 0}, Frame(5)).ok());
  }
  const std::string journal = *ReadFile(dir_ / "journal.jsonl");
  const auto refusal = [&](const std::string& text) {
    EXPECT_TRUE(WriteFileAtomically(dir_ / "journal.jsonl", text).ok());
    const Result<CaptureStore> opened = CaptureStore::Open(dir_);
    EXPECT_FALSE(opened.ok()) << text;
    return opened.ok() ? std::string("accepted") : opened.status().ToString();
  };
  std::string edited = journal;
  const size_t exposure = edited.find("1250.5");
  ASSERT_NE(exposure, std::string::npos);
  edited[exposure] = '9';
  EXPECT_NE(refusal(edited).find("journal.jsonl, line 1: breaks its hash chain"), std::string::npos) << refusal(edited);
  const std::string without_first = journal.substr(journal.find('\n') + 1);
  EXPECT_NE(refusal(without_first).find("line 1: breaks its hash chain"), std::string::npos);

  // An old scan's journal, without the chain, still reads ...
  std::vector<std::string> lines = UnchainedLines(journal);
  ASSERT_EQ(lines.size(), 4u);
  ASSERT_TRUE(WriteFileAtomically(dir_ / "journal.jsonl", Joined(lines)).ok());
  ASSERT_EQ(CaptureStore::Open(dir_)->records().size(), 3u);
  // ... but not with a record twice, a step done twice, or a frame the plan cannot have made.
  std::vector<std::string> twice = lines;
  twice.insert(twice.begin() + 2, lines[0]);
  EXPECT_NE(refusal(Joined(twice)).find("line 3: records frames/s00000_cam0_e00.exr a second time"), std::string::npos);
  twice = lines;
  twice.push_back(lines[3]);
  EXPECT_NE(refusal(Joined(twice)).find("line 5: marks step 0 done twice"), std::string::npos);
  std::vector<std::string> impossible = lines;
  impossible[1].replace(impossible[1].find(R"("step":0)"), 8, R"("step":7)");
  EXPECT_NE(refusal(Joined(impossible)).find("line 2: records a frame of step 7, which the plan (2 steps) does not have"),
            std::string::npos);
  impossible = lines;
  impossible[2].replace(impossible[2].find("frames/s00000_cam0_e02.exr"), 26, "../../../etc/passwd");
  EXPECT_NE(refusal(Joined(impossible)).find("line 3: names the frame's file '../../../etc/passwd'"), std::string::npos);
  // A chained line after it came: removing a link is an edit.
  ASSERT_TRUE(WriteFileAtomically(dir_ / "journal.jsonl", journal).ok());
  std::vector<std::string> unlinked = UnchainedLines(journal);
  unlinked[0] = journal.substr(0, journal.find('\n'));
  EXPECT_NE(refusal(Joined(unlinked)).find("line 2: has lost its chain link"), std::string::npos);
}

TEST_F(CaptureStoreTest, VerifyingReportsDamagedPartialAndForeignFilesAndChangesNothing) {
  {
    CaptureStore store = MakeStore();
    for (int e = 0; e < 2; ++e) ASSERT_TRUE(store.Append({0, "cam0", e}, Frame(e)).ok());
    ASSERT_TRUE(store.MarkStepDone(0).ok());
  }
  Result<ScanIntegrity> intact = VerifyScan(dir_);
  ASSERT_TRUE(intact.ok()) << intact.status().ToString();
  EXPECT_TRUE(intact->intact());
  EXPECT_FALSE(intact->complete());
  EXPECT_EQ(intact->frames_verified, 2);
  EXPECT_EQ(intact->steps_planned, 2);

  ASSERT_TRUE(WriteExrUint16(dir_ / "frames/s00000_cam0_e01.exr", 16, 12, Frame(9).pixels, "DN").ok());
  ASSERT_TRUE(WriteExrUint16(dir_ / "frames/s00001_cam0_e00.exr", 16, 12, Frame(3).pixels, "DN").ok());
  std::ofstream(dir_ / "frames/notes.txt") << "the operator's";
  std::ofstream(dir_ / "journal.jsonl", std::ios::app) << R"({"step_done")";
  const std::string journal = *ReadFile(dir_ / "journal.jsonl");
  const Result<ScanIntegrity> damaged = VerifyScan(dir_);
  ASSERT_TRUE(damaged.ok()) << damaged.status().ToString();
  EXPECT_FALSE(damaged->intact());
  EXPECT_EQ(damaged->frames_verified, 1);
  ASSERT_EQ(damaged->damaged.size(), 1u);
  EXPECT_EQ(damaged->damaged[0].subject(), (dir_ / "frames/s00000_cam0_e01.exr").string());
  EXPECT_TRUE(damaged->torn_last_line);
  EXPECT_EQ(damaged->partial_frames, std::vector<std::string>{(dir_ / "frames/s00001_cam0_e00.exr").string()});
  EXPECT_EQ(damaged->foreign_files, std::vector<std::string>{(dir_ / "frames/notes.txt").string()});
  std::ostringstream report;
  damaged->Report(report);
  EXPECT_NE(report.str().find("1 of 2 recorded frames verified"), std::string::npos) << report.str();
  EXPECT_NE(report.str().find("DAMAGED"), std::string::npos) << report.str();
  // Nothing was repaired or removed.
  EXPECT_EQ(*ReadFile(dir_ / "journal.jsonl"), journal);
  EXPECT_TRUE(fs::exists(dir_ / "frames/s00001_cam0_e00.exr"));
}

// Two `loom scan --resume` on one directory once both ran, and left 466 journal records for
// 238 frames: a second writer is now refused, naming the scan, until the first one ends.
TEST_F(CaptureStoreTest, ASecondWriterIsRefusedUntilTheFirstEnds) {
  {
    CaptureStore writer = MakeStore();
    const Result<CaptureStore> second = CaptureStore::Open(dir_, /*repair=*/true);
    ASSERT_FALSE(second.ok());
    EXPECT_EQ(second.status().code(), StatusCode::kFailedPrecondition);
    EXPECT_EQ(second.status().subject(), dir_.string());
    EXPECT_NE(second.status().message().find("pid " + std::to_string(::getpid())), std::string::npos)
        << second.status().ToString();
    EXPECT_TRUE(CaptureStore::Open(dir_).ok()) << "readers are not writers";
    ASSERT_TRUE(writer.Append({0, "cam0", 0}, Frame(0)).ok());
  }
  Result<CaptureStore> resumed = CaptureStore::Open(dir_, /*repair=*/true);
  ASSERT_TRUE(resumed.ok()) << resumed.status().ToString();
  EXPECT_EQ(resumed->records().size(), 1u);
  EXPECT_EQ(CaptureStore::Open(dir_, /*repair=*/true).status().code(), StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace loom::scan
