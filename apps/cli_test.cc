// Runs the real `loom` binary and checks what a user sees: output, stderr and exit codes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "core/testing/build_tree.h"
#include "core/testing/subprocess.h"
#include "core/version.h"

namespace {

using LoomRun = loom::testing::CommandResult;

LoomRun RunLoom(const std::string& arguments) { return loom::testing::RunCommand(loom::testing::LoomBinary() + " " + arguments); }

bool Contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

TEST(CliTest, HelpListsEveryCommand) {
  const LoomRun run = RunLoom("--help");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_TRUE(Contains(run.output, "Usage: loom")) << run.output;
  EXPECT_TRUE(Contains(run.output, "  version ")) << run.output;
  EXPECT_TRUE(Contains(run.output, "  help ")) << run.output;
}

// LibTorch is loaded by the commands that use the CNN, not by every start (fitting/internal/
// fitting/cnn/internal/cnn_engine.h: ~0.9 s of CPU and ~150 MB each): the dynamic loader's log names what it loads.
TEST(CliTest, OnlyTheCommandsThatUseTheCnnLoadLibTorch) {
  const LoomRun version = loom::testing::RunCommand("LD_DEBUG=files " + loom::testing::LoomBinary() + " version");
  EXPECT_EQ(version.exit_code, 0) << version.output;
  EXPECT_TRUE(Contains(version.output, "libstdc++")) << version.output;  // the log is there
  EXPECT_FALSE(Contains(version.output, "libtorch")) << version.output;
  const LoomRun model = loom::testing::RunCommand("LD_DEBUG=files " + loom::testing::LoomBinary() + " model " +
                                                  loom::testing::SourceDir() + "/configs/models/tac7-mini");
  EXPECT_EQ(model.exit_code, 0) << model.output;
  EXPECT_TRUE(Contains(model.output, "libloom_cnn_torch.so")) << model.output;
  EXPECT_TRUE(Contains(model.output, "libtorch_cpu.so")) << model.output;
}

// A config named by NAME (`--preset low`, demo's `--rig tac7`) is configs/<folder>/NAME.yaml even
// where the working directory holds a directory of that name (a model's, a scan's).
TEST(CliTest, ADirectoryNamedLikeAConfigDoesNotShadowIt) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / ("cli_config_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir / "low");
  const LoomRun run = loom::testing::RunCommand("cd " + dir.string() + " && " + loom::testing::LoomBinary() + " plan --rig " +
                                                loom::testing::SourceDir() + "/configs/rig/tac7-mini.yaml --preset low");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("with preset 'low'"), std::string::npos) << run.output;
  std::filesystem::remove_all(dir);
}

// Every command's --rig takes a rig's name as demo's does; a name that is no rig is named.
TEST(CliTest, ARigIsFoundByItsNameAndAMissingOneIsNamed) {
  const LoomRun plan = RunLoom("plan --rig tac7-mini --preset low");
  EXPECT_EQ(plan.exit_code, 0) << plan.output;
  EXPECT_NE(plan.output.find("with preset 'low'"), std::string::npos) << plan.output;
  const LoomRun list = RunLoom("rig list --rig tac7-mini");
  EXPECT_EQ(list.exit_code, 0) << list.output;
  const LoomRun missing =
      RunLoom("sim render --rig no-such-rig --stack --size 8 --out " + ::testing::TempDir() + "/cli_never_written.exr");
  EXPECT_EQ(missing.exit_code, 1) << missing.output;
  EXPECT_NE(missing.output.find("no-such-rig"), std::string::npos) << missing.output;
}

TEST(CliTest, NoCommandIsAUsageError) {
  const LoomRun run = RunLoom("");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_TRUE(Contains(run.output, "Commands:")) << run.output;
}

TEST(CliTest, UnknownCommandIsAUsageError) {
  const LoomRun run = RunLoom("scna");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_TRUE(Contains(run.output, "unknown command 'scna'")) << run.output;
}

TEST(CliTest, EveryCommandHasHelp) {
  for (const char* command : {"calibrate", "help", "plan", "rig", "scan", "sim", "version"}) {
    const LoomRun run = RunLoom(std::string(command) + " --help");
    EXPECT_EQ(run.exit_code, 0) << command << ": " << run.output;
    EXPECT_TRUE(Contains(run.output, "--log-level")) << command << ": " << run.output;
    const LoomRun via_help = RunLoom(std::string("help ") + command);
    EXPECT_EQ(via_help.exit_code, 0) << command;
    EXPECT_EQ(via_help.output, run.output) << command;
  }
}

TEST(CliTest, CalibrateIntrinsicsFromPhotosWritesACalibrationFile) {
  const std::string out = ::testing::TempDir() + "/cli_intrinsics_" + std::to_string(::getpid()) + ".yaml";
  const LoomRun run = RunLoom("calibrate intrinsics --images '" + loom::testing::SourceDir() +
                              "/calibration/testdata/opencv-left/left0*.jpg' --board chessboard:9x6:25 --name cam3 --out " + out);
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_TRUE(Contains(run.output, "board found in 9 of 9 images")) << run.output;
  EXPECT_TRUE(Contains(run.output, "RMS reprojection error 0.")) << run.output;
  const LoomRun bad = RunLoom("calibrate intrinsics --images '/nowhere/*.jpg' --out " + out);
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_TRUE(Contains(bad.output, "images '/nowhere/*.jpg': matches no file")) << bad.output;
  const LoomRun typo = RunLoom("calibrate intrinsics --images x --board chessbord:9x6:25 --out " + out);
  EXPECT_EQ(typo.exit_code, 1);
  EXPECT_TRUE(Contains(typo.output, "board 'chessbord:9x6:25'")) << typo.output;
  const LoomRun again = RunLoom("calibrate intrinsics --images '" + loom::testing::SourceDir() +
                                "/calibration/testdata/opencv-left/left0*.jpg' --name cam3 --out " + out);
  EXPECT_EQ(again.exit_code, 0) << "a re-run replaces the file loom wrote: " << again.output;
  std::filesystem::remove(out);
}

TEST(CliTest, VersionNamesLoomAndItsLibraries) {
  const LoomRun run = RunLoom("version");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_TRUE(Contains(run.output, "loom " + std::string(loom::Version()))) << run.output;
  for (const char* library : {"Aravis", "libmodbus", "libusb", "OpenCV", "Ceres", "OpenEXR", "LibTorch"}) {
    EXPECT_TRUE(Contains(run.output, library)) << library << " missing in:\n" << run.output;
  }
  EXPECT_EQ(RunLoom("version --short").output, std::string(loom::Version()) + "\n");
  const LoomRun devices = RunLoom("version --devices");  // Debian's LibTorch is CPU-only
  EXPECT_EQ(devices.exit_code, 0) << devices.output;
  EXPECT_TRUE(Contains(devices.output, "\n  devices   cpu\n")) << devices.output;
}

// The commit is looked up when loom is built, not when the build was configured: otherwise an
// incremental build names the configure run's commit.
TEST(CliTest, VersionNamesTheCommitItWasBuiltFrom) {
  const LoomRun head = loom::testing::RunCommand("git -C " + loom::testing::SourceDir() + " rev-parse --short HEAD");
  if (head.exit_code != 0) GTEST_SKIP() << "not built from a git checkout";
  const std::string commit = head.output.substr(0, head.output.find_first_of("\n"));
  const LoomRun run = RunLoom("version");
  EXPECT_TRUE(Contains(run.output, "(git " + commit + ")") || Contains(run.output, "(git " + commit + "-dirty)"))
      << "HEAD is " << commit << "; loom says:\n"
      << run.output;
}

// loom model shows the shipped model (stored as float16) and copies it with float32 weights and
// back: twice the file and half again, the files beside it copied, the original never overwritten.
TEST(CliTest, ModelShowsAModelAndCopiesItWithOtherWeights) {
  const std::string shipped = loom::testing::SourceDir() + "/configs/models/tac7-mini";
  const LoomRun show = RunLoom("model " + shipped);
  EXPECT_EQ(show.exit_code, 0) << show.output;
  EXPECT_TRUE(Contains(show.output, "rig tac7-mini, 232 input channels")) << show.output;
  EXPECT_TRUE(Contains(show.output, "weights float16")) << show.output;
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / ("cli_model_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const LoomRun wide = RunLoom("model " + shipped + " --out " + (dir / "32").string() + " --weights float32");
  ASSERT_EQ(wide.exit_code, 0) << wide.output;
  const LoomRun narrow = RunLoom("model " + (dir / "32").string() + " --out " + (dir / "16").string() + " --weights float16");
  ASSERT_EQ(narrow.exit_code, 0) << narrow.output;
  const auto size = [](const std::filesystem::path& model) { return std::filesystem::file_size(model / "weights.pt"); };
  EXPECT_GT(size(dir / "32"), 1.98 * size(shipped));
  // The same float16 weights: the same size up to the zip's record names (a few hundred bytes).
  EXPECT_NEAR(static_cast<double>(size(dir / "16")), static_cast<double>(size(shipped)), 4096);
  EXPECT_TRUE(std::filesystem::exists(dir / "16" / "refine.json"));
  EXPECT_TRUE(Contains(RunLoom("model " + (dir / "32").string()).output, "weights float32"));
  const LoomRun in_place = RunLoom("model " + (dir / "16").string() + " --out " + (dir / "16").string() + " --weights float32");
  EXPECT_EQ(in_place.exit_code, 1) << in_place.output;
  EXPECT_TRUE(Contains(in_place.output, "is the model itself")) << in_place.output;
  EXPECT_EQ(RunLoom("model " + shipped + " --weights float64 --out " + dir.string()).exit_code, 2);
  std::filesystem::remove_all(dir);
}

// loom model --average writes the uniform average of models of one network, and refuses another
// rig's model, naming it, or an average with nowhere to go.
TEST(CliTest, ModelAveragesTheWeightsOfModelsOfOneNetwork) {
  const std::string shipped = loom::testing::SourceDir() + "/configs/models/tac7-mini";
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / ("cli_average_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  ASSERT_EQ(RunLoom("model " + shipped + " --out " + (dir / "32").string() + " --weights float32").exit_code, 0);
  const LoomRun mean = RunLoom("model " + shipped + " --average " + (dir / "32").string() + " --out " + (dir / "mean").string() +
                               " --weights float16");
  ASSERT_EQ(mean.exit_code, 0) << mean.output;
  EXPECT_NEAR(static_cast<double>(std::filesystem::file_size(dir / "mean" / "weights.pt")),
              static_cast<double>(std::filesystem::file_size(shipped + "/weights.pt")), 4096);
  EXPECT_TRUE(Contains(RunLoom("model " + (dir / "mean").string()).output, "the uniform average of the weights of 2 models"));
  const std::string other_rig = loom::testing::SourceDir() + "/configs/models/tac7";
  const LoomRun mixed = RunLoom("model " + shipped + " --average " + other_rig + " --out " + (dir / "mixed").string());
  EXPECT_EQ(mixed.exit_code, 1) << mixed.output;
  EXPECT_TRUE(Contains(mixed.output, other_rig) && Contains(mixed.output, "rig 'tac7'")) << mixed.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "mixed"));
  const LoomRun nowhere = RunLoom("model " + shipped + " --average " + (dir / "32").string());
  EXPECT_EQ(nowhere.exit_code, 2) << nowhere.output;  // a usage error
  EXPECT_TRUE(Contains(nowhere.output, "--average requires --out")) << nowhere.output;
  std::filesystem::remove_all(dir);
}

TEST(CliTest, ShippedRigFilesLoad) {
  // Loading creates every device through its backend without connecting to any.
  const LoomRun run = RunLoom("rig list --rig " + loom::testing::SourceDir() + "/configs/rig/peer.yaml");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_TRUE(Contains(run.output, "rig 'peer'")) << run.output;
  EXPECT_TRUE(Contains(run.output, "5 devices")) << run.output;
}

TEST(CliTest, SimulatedRigsLoadAndSnap) {
  for (const char* rig : {"tac7", "tac7-mini"}) {
    const LoomRun list = RunLoom("rig list --rig " + loom::testing::SourceDir() + "/configs/rig/" + rig + ".yaml");
    EXPECT_EQ(list.exit_code, 0) << list.output;
    EXPECT_TRUE(Contains(list.output, "simulated")) << list.output;
  }
  const std::string out = ::testing::TempDir() + "/tac7_mini_cam1.exr";
  const LoomRun snap = RunLoom("rig snap --rig " + loom::testing::SourceDir() +
                               "/configs/rig/tac7-mini.yaml --camera cam1 --leds 3:1000 --out " + out);
  EXPECT_EQ(snap.exit_code, 0) << snap.output;
  EXPECT_TRUE(Contains(snap.output, "160x160 Mono12")) << snap.output;
}

TEST(CliTest, PlanShowsCountsAndDuration) {
  const LoomRun run = RunLoom("plan --rig " + loom::testing::SourceDir() + "/configs/rig/tac7.yaml --preset high");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_TRUE(Contains(run.output, "monochrome           87 steps    348 images")) << run.output;
  EXPECT_TRUE(Contains(run.output, "linear light        825 steps   3300 images")) << run.output;
  EXPECT_TRUE(Contains(run.output, "colour               50 steps    100 images")) << run.output;
  EXPECT_TRUE(Contains(run.output, "estimated duration:")) << run.output;
  const LoomRun missing = RunLoom("plan --rig " + loom::testing::SourceDir() + "/configs/rig/peer.yaml");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_TRUE(Contains(missing.output, "has no 'geometry:' section")) << missing.output;
}

TEST(CliTest, BadOptionsAreUsageErrorsOnStderr) {
  const LoomRun bogus = RunLoom("version --bogus");
  EXPECT_EQ(bogus.exit_code, 2) << bogus.output;
  EXPECT_TRUE(Contains(bogus.output, "--bogus")) << bogus.output;
  const LoomRun level = RunLoom("version --log-level loud");
  EXPECT_EQ(level.exit_code, 2) << level.output;
  EXPECT_TRUE(Contains(level.output, "loud")) << level.output;
  EXPECT_EQ(RunLoom("--log-level debug version --short").exit_code, 0);
  EXPECT_EQ(RunLoom("--log-level loud version").exit_code, 2);
}

}  // namespace
