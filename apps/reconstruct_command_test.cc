// loom scan → loom reconstruct on the simulated tac7-mini with finer cameras (a short plan: the
// paper's three turntable angles, 4 strip positions), scored against the simulator's ground
// truth: the heightmap against the fabric's, the reconstructed stack against the fast-path stack
// of the same plan — what an ideal reconstruction would give. Also: bad scans fail naming what
// is wrong.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/exr_io.h"
#include "core/observation_stack.h"
#include "core/testing/build_tree.h"
#include "core/testing/subprocess.h"

namespace {

namespace fs = std::filesystem;
using loom::testing::RunCommand;

std::string Loom(const std::string& arguments) { return loom::testing::LoomBinary() + " " + arguments; }

// Replaces every `from` in `text`; returns how many there were.
int ReplaceAll(std::string& text, const std::string& from, const std::string& to) {
  int count = 0;
  for (size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()), ++count) {
    text.replace(at, from.size(), to);
  }
  return count;
}

// tac7-mini's cameras see the sample at the stacks' 0.2 mm; tac7's, like a real scanner's, at
// 0.073 mm, and the stack is resampled from finer images. This rig is tac7-mini with cameras at
// 0.08 mm (2.5 times finer than the stack) and, to keep the scan short, a 64 px (12.8 mm) sample.
void WriteFineCameraRig(const fs::path& path) {
  std::ifstream in(loom::testing::SourceDir() + "/configs/rig/tac7-mini.yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::string rig = text.str();
  ASSERT_EQ(ReplaceAll(rig, "resolution: [160, 160]", "resolution: [240, 240]"), 2);
  ASSERT_EQ(ReplaceAll(rig, "focal_px: [3000, 3000]", "focal_px: [7500, 7500]"), 2);
  ASSERT_EQ(ReplaceAll(rig, "size_px: 128", "size_px: 64"), 1);
  std::ofstream(path) << rig;
}

// Scans, reconstructs and renders the fast path into `dir`.
void ScanAndReconstruct(const fs::path& dir) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "short.yaml") << "schema_version: 1\npreset: short\nturntable_deg: [0, 120, 240]\n"
                                       "linear_light_positions: 4\nmax_exposures: 3\n";
  const std::string rig = (dir / "fine-cameras.yaml").string();
  WriteFineCameraRig(rig);
  if (::testing::Test::HasFatalFailure()) return;
  const std::string preset = (dir / "short.yaml").string();
  const auto scan = RunCommand(
      Loom("scan --rig " + rig + " --preset " + preset + " --object fabric:1 --out " + (dir / "scan").string() + " --quiet"));
  ASSERT_EQ(scan.exit_code, 0) << scan.output;
  const auto reconstruct =
      RunCommand(Loom("reconstruct " + (dir / "scan").string() + " --size 64 --out " + (dir / "rec").string() + " --quiet"));
  ASSERT_EQ(reconstruct.exit_code, 0) << reconstruct.output;
  // cam1, 45° from the normal, sees the sample foreshortened: 2.5 · cos 45° camera pixels per
  // stack pixel, below 2, which the note says.
  EXPECT_NE(reconstruct.output.find("span 2.50 (cam0), 1.77 (cam1) camera pixels"), std::string::npos) << reconstruct.output;
  const auto render = RunCommand(Loom("sim render --rig " + rig + " --stack --preset " + preset + " --truth " +
                                      (dir / "truth.exr").string() + " --out " + (dir / "fast.exr").string()));
  ASSERT_EQ(render.exit_code, 0) << render.output;
}

double Median(std::vector<double> values) {
  if (values.empty()) return NAN;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

void TheHeightmapMatchesTheFabrics(const fs::path& dir) {
  const auto stack = loom::ReadObservationStack(dir / "rec/stack.exr");
  ASSERT_TRUE(stack.ok()) << stack.status().ToString();
  const auto truth = loom::ReadExr(dir / "truth.exr");
  ASSERT_TRUE(truth.ok()) << truth.status().ToString();
  const int height = *truth->image.ChannelIndex("height");
  double sum2 = 0;
  double truth_sum2 = 0;
  const int w = stack->image.width();
  const int h = stack->image.height();
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double error = stack->image.at(2, y, x) - truth->image.at(height, y, x);
      sum2 += error * error;
      truth_sum2 += truth->image.at(height, y, x) * truth->image.at(height, y, x);
    }
  }
  const double rms = std::sqrt(sum2 / (w * h));
  ::testing::Test::RecordProperty("height_rms_mm", std::to_string(rms));
  std::cout << "height RMS error " << rms << " mm (the fabric's RMS height " << std::sqrt(truth_sum2 / (w * h)) << " mm)\n";
  // Measured: 0.019 mm against a fabric of 0.19 mm RMS relief (0.028 mm with
  // tac7-mini's own cameras); the bound is the goal for tac7 (≤ 0.05 mm).
  EXPECT_LT(rms, 0.05);
}

void TheSamplingIsRecorded(const fs::path& dir) {
  std::ifstream file(dir / "rec/reconstruction.json");
  const nlohmann::json summary = nlohmann::json::parse(file, nullptr, false);
  ASSERT_FALSE(summary.is_discarded());
  EXPECT_NEAR(summary["camera_px_per_stack_px"]["cam0"].get<double>(), 2.5, 0.01);    // 0.2 mm / 0.08 mm
  EXPECT_NEAR(summary["camera_px_per_stack_px"]["cam1"].get<double>(), 1.768, 0.01);  // · cos 45°
}

void TheStackMatchesTheFastPathOutsideShadows(const fs::path& dir) {
  const auto stack = loom::ReadObservationStack(dir / "rec/stack.exr");
  ASSERT_TRUE(stack.ok()) << stack.status().ToString();
  const auto fast = loom::ReadObservationStack(dir / "fast.exr");
  ASSERT_TRUE(fast.ok()) << fast.status().ToString();
  ASSERT_EQ(stack->observations.size(), fast->observations.size());
  std::vector<double> relative;
  for (size_t k = 0; k < fast->observations.size(); ++k) {
    EXPECT_EQ(stack->observations[k].group, fast->observations[k].group) << k;
    EXPECT_EQ(stack->observations[k].camera, fast->observations[k].camera) << k;
    EXPECT_LT((stack->observations[k].rgb_weights - fast->observations[k].rgb_weights).norm(), 1e-12) << k;
    const int c = loom::ObservationStack::ObservationChannel(static_cast<int>(k));
    const auto reconstructed = stack->image.channel(c);
    const auto ideal = fast->image.channel(c);
    std::vector<double> lit;
    for (float v : ideal) {
      if (std::isfinite(v)) lit.push_back(v);
    }
    const double typical = Median(lit);
    for (size_t i = 0; i < ideal.size(); ++i) {
      // Outside shadows: where the ideal value is at least a tenth of the observation's median.
      if (!std::isfinite(ideal[i]) || !std::isfinite(reconstructed[i]) || ideal[i] < 0.1 * typical) continue;
      relative.push_back(std::abs(reconstructed[i] - ideal[i]) / ideal[i]);
    }
  }
  const double median = Median(relative);
  std::cout << "median relative error against the fast path " << 100 * median << " % over " << relative.size() << " samples\n";
  // Measured: 1.51 % median; per observation the median ratio is 0.98-1.00, so no
  // radiometric bias. The rest is sampling: the fast path samples points, a camera pixel
  // integrates the fabric's 0.2 mm texture and highlights over its footprint and the
  // resampling spreads that further. The same scan with cameras 2 times finer than the stack
  // gives 2.0 %, with tac7-mini's own (as coarse as the stack) 6.3 % (ratios 0.89-1.12).
  // Since cam1 (1.77 camera pixels per stack pixel) is interpolated bicubically rather than
  // bilinearly: 1.89 % (bicubic weights average fewer camera pixels).
  // Bound: the goal, 2 %.
  EXPECT_LT(median, 0.02);
}

void AMissingFrameIsAnErrorNamingItAndNothingIsWritten(const fs::path& dir) {
  const fs::path copy = dir / "scan-missing";
  fs::copy(dir / "scan", copy, fs::copy_options::recursive);
  fs::path victim;
  for (const auto& entry : fs::directory_iterator(copy / "frames")) {
    if (entry.path().filename().string().starts_with("s00030_")) victim = entry.path();
  }
  ASSERT_FALSE(victim.empty());
  fs::remove(victim);
  const auto run = RunCommand(Loom("reconstruct " + copy.string() + " --out " + (dir / "rec-missing").string() + " --quiet"));
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find(victim.filename().string()), std::string::npos) << run.output;
  EXPECT_FALSE(fs::exists(dir / "rec-missing/stack.exr"));
}

void ACameraCalibrationOfAnotherSizeIsAnErrorNamingTheFile(const fs::path& dir) {
  const fs::path calib = dir / "calib";
  fs::create_directories(calib);
  std::ofstream(calib / "cam0.yaml") << "schema_version: 1\ndevice: camera\nname: cam0\n"
                                        "model: pinhole + OpenCV 5-term distortion (k1 k2 p1 p2 k3); pixel centres at integers\n"
                                        "image_size_px: [640, 480]\nK_px: [[500, 0, 320], [0, 500, 240], [0, 0, 1]]\n"
                                        "distortion: [0, 0, 0, 0, 0]\nquality: {rms_px: 0.2, views: [], skipped: []}\n"
                                        "source: {from: test, board: 'chessboard:9x6:25'}\n";
  const auto run = RunCommand(Loom("reconstruct " + (dir / "scan").string() + " --calib " + calib.string() + " --out " +
                                   (dir / "rec-calib").string() + " --quiet"));
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find("cam0.yaml"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("640x480"), std::string::npos) << run.output;
}

// A scan of a crop whose cameras read only the windows that see it (`--crop-mm`: GenICam regions
// of interest, from the rig's geometry) reconstructs the sample's centre as the full scan does:
// the frames are the full frames' crops, and the reconstruction places them on the sensor.
void AWindowedScanReconstructsTheCentreAsTheFullScanDoes(const fs::path& dir) {
  const std::string preset = (dir / "short.yaml").string();
  const auto scan = RunCommand(Loom("scan --rig " + (dir / "fine-cameras.yaml").string() + " --preset " + preset +
                                    " --object fabric:1 --crop-mm 6.4 --out " + (dir / "windowed-scan").string()));
  ASSERT_EQ(scan.exit_code, 0) << scan.output;
  // 6.4 mm at 0.08 mm per pixel: the crop's circle at every angle is 113 px across in cam0, with
  // 8 px of margin each side and 8-px alignment 144 of its 240 (cam1, 45° off: 136 × 144).
  EXPECT_NE(scan.output.find("cam0 reads 144x144 px at 48,48 for the 6.4 mm crop"), std::string::npos) << scan.output;
  // The scan keeps its crop: a resume reads the same windows.
  const auto resume = RunCommand(Loom("scan --resume " + (dir / "windowed-scan").string()));
  EXPECT_EQ(resume.exit_code, 0) << resume.output;
  EXPECT_NE(resume.output.find("cam0 reads 144x144 px at 48,48 for the 6.4 mm crop"), std::string::npos) << resume.output;
  for (const std::string name : {"windowed-scan", "scan"}) {
    const auto reconstruct = RunCommand(
        Loom("reconstruct " + (dir / name).string() + " --size 32 --out " + (dir / (name + "-centre")).string() + " --quiet"));
    ASSERT_EQ(reconstruct.exit_code, 0) << reconstruct.output;
  }
  const auto windowed = loom::ReadObservationStack(dir / "windowed-scan-centre/stack.exr");
  ASSERT_TRUE(windowed.ok()) << windowed.status().ToString();
  const auto full = loom::ReadObservationStack(dir / "scan-centre/stack.exr");
  ASSERT_TRUE(full.ok()) << full.status().ToString();
  ASSERT_EQ(windowed->image.num_channels(), full->image.num_channels());
  double height_error = 0;
  std::vector<double> relative;
  int unseen = 0;
  for (int c = 0; c < full->image.num_channels(); ++c) {
    const auto a = windowed->image.channel(c);
    const auto b = full->image.channel(c);
    for (size_t i = 0; i < b.size(); ++i) {
      if (c == 2) height_error = std::max(height_error, static_cast<double>(std::abs(a[i] - b[i])));
      if (c < loom::kStackGeometryChannels || !std::isfinite(b[i])) continue;
      if (!std::isfinite(a[i])) {
        ++unseen;
        continue;
      }
      if (b[i] > 0) relative.push_back(std::abs(a[i] - b[i]) / b[i]);
    }
  }
  std::sort(relative.begin(), relative.end());
  std::cout << "windowed against full scan: heights within " << height_error << " mm, values median "
            << relative[relative.size() / 2] << ", p99 " << relative[relative.size() * 99 / 100] << ", " << unseen
            << " values unseen\n";
  // Measured: every value and height the full scan's, bit for bit. A bracket may
  // differ where the full frame's dark corners ask for a longer exposure than the window does (a
  // hand-set 128 px window did so for one step: another noise draw, p99 1.3 %): hence p99's bound.
  EXPECT_EQ(unseen, 0);
  EXPECT_LT(height_error, 1e-6);
  EXPECT_LT(relative[relative.size() / 2], 1e-6);
  EXPECT_LT(relative[relative.size() * 99 / 100], 0.03);
}

// One test, one scan: the scan is what takes the time (ctest runs each TEST as a process).
TEST(ReconstructCommandTest, ScanReconstructScoreAndRefuseBadInput) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("reconstruct_command_test_" + std::to_string(::getpid()));
  ScanAndReconstruct(dir);
  if (HasFatalFailure()) return;
  {
    SCOPED_TRACE("the heightmap matches the fabric's");
    TheHeightmapMatchesTheFabrics(dir);
  }
  {
    SCOPED_TRACE("how finely each camera samples the stack is recorded");
    TheSamplingIsRecorded(dir);
  }
  {
    SCOPED_TRACE("the stack matches the fast path outside shadows");
    TheStackMatchesTheFastPathOutsideShadows(dir);
  }
  {
    SCOPED_TRACE("a windowed scan reconstructs the centre as the full scan does");
    AWindowedScanReconstructsTheCentreAsTheFullScanDoes(dir);
  }
  {
    SCOPED_TRACE("a missing frame is an error naming it; nothing is written");
    AMissingFrameIsAnErrorNamingItAndNothingIsWritten(dir);
  }
  {
    SCOPED_TRACE("a camera calibration of another size is an error naming the file");
    ACameraCalibrationOfAnotherSizeIsAnErrorNamingTheFile(dir);
  }
  fs::remove_all(dir);
}

}  // namespace
