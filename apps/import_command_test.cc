// loom sim capture → loom import → loom fit → loom eval on simulated curved objects in the layouts
// of photometric-stereo benchmarks and light domes: the chain runs on captures from other rigs,
// masks are skipped and counted, the normals are recovered against the truth, and a held-out view
// scores a fit.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "core/testing/build_tree.h"
#include "core/testing/subprocess.h"

namespace {

namespace fs = std::filesystem;
using loom::testing::RunCommand;

class ImportCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("import_command_test_" + std::to_string(::getpid()) + "_" +
                                             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Loom(const std::string& arguments) const { return loom::testing::LoomBinary() + " " + arguments; }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  nlohmann::json Json(const std::string& name) const {
    std::ifstream in(dir_ / name);
    return nlohmann::json::parse(in);
  }

  // A shape's capture of `lights` images on `size` × `size` px, imported at the scale it was stored
  // with (the truth's units).
  void CaptureAndImport(const std::string& shape, const std::string& more = "", int size = 32, int lights = 24) {
    const auto capture = RunCommand(Loom("sim capture --shape " + shape + " --size " + std::to_string(size) + " --lights " +
                                         std::to_string(lights) + " --truth " + Path("truth.exr") + " --normals " +
                                         Path("normals.exr") + " --out " + Path("capture") + " " + more));
    ASSERT_EQ(capture.exit_code, 0) << capture.output;
    const auto imported = RunCommand(Loom("import " + Path("capture") + " --scale 1 --out " + Path("stack.exr")));
    ASSERT_EQ(imported.exit_code, 0) << imported.output;
    EXPECT_NE(imported.output.find("imported " + std::to_string(lights) + " images (ps, linear)"), std::string::npos)
        << imported.output;
  }

  // Fits with `method` (and `options`, the fit named `name`) and scores the normals; returns
  // normals.json.
  nlohmann::json FitAndScoreNormals(const std::string& method, const std::string& options = "", std::string name = "") {
    if (name.empty()) name = method;
    const auto fit = RunCommand(
        Loom("fit " + Path("stack.exr") + " --method " + method + " " + options + " --out " + Path("fit-" + name) + " --quiet"));
    EXPECT_EQ(fit.exit_code, 0) << fit.output;
    fit_output_ = fit.output;
    const auto eval = RunCommand(Loom("eval " + Path("fit-" + name + "/svbrdf.exr") + " --stack " + Path("stack.exr") +
                                      " --reference " + Path("truth.exr") + " --reference-normals " + Path("normals.exr") +
                                      " --renderer-views 0 --out " + Path("eval-" + name)));
    EXPECT_EQ(eval.exit_code, 0) << eval.output;
    EXPECT_NE(eval.output.find("normals against the reference"), std::string::npos) << eval.output;
    return Json("eval-" + name + "/normals.json");
  }

  // Fits train.exr with `method` and returns the relative L1 of the view held out of it (held.exr).
  double HeldOutL1(const std::string& method) {
    const auto fit = RunCommand(Loom("fit " + Path("train.exr") + " --method " + method + " --out " + Path(method) + " --quiet"));
    EXPECT_EQ(fit.exit_code, 0) << fit.output;
    const auto eval = RunCommand(Loom("eval " + Path(method + "/svbrdf.exr") + " --stack " + Path("held.exr") +
                                      " --renderer-views 0 --out " + Path(method + "-held")));
    EXPECT_EQ(eval.exit_code, 0) << eval.output;
    return Json(method + "-held/summary.json")["rerender_l1"]["fit"]["all"]["relative_l1"].get<double>();
  }

  fs::path dir_;
  std::string fit_output_;  // the last FitAndScoreNormals' fit's
};

TEST_F(ImportCommandTest, ASphereIsFittedAroundItsMaskToItsTrueNormals) {
  CaptureAndImport("sphere");
  const nlohmann::json lambert = FitAndScoreNormals("lambert");
  const nlohmann::json ceres = FitAndScoreNormals("ceres");
  // The mask: the pixels off the sphere are skipped and counted, never an error.
  const nlohmann::json fit = Json("fit-ceres/fit.json");
  const int masked = 32 * 32 - fit["pixels_fitted"].get<int>();
  EXPECT_GT(masked, 200);
  EXPECT_EQ(fit["pixels_skipped"].get<int>(), masked);
  EXPECT_EQ(ceres["pixels"].get<int>(), fit["pixels_fitted"].get<int>());
  // Photographs from another rig are fitted by ceres unless --method says otherwise.
  const auto by_default = RunCommand(Loom("fit " + Path("stack.exr") + " --quiet --out " + Path("fit-default")));
  ASSERT_EQ(by_default.exit_code, 0) << by_default.output;
  EXPECT_EQ(Json("fit-default/fit.json")["method"], "ceres");
  // Noise-free GD10: the target is a median ≤ 0.3° and a p90 ≤ 1°; measured 0.00° and
  // 0.00° (mean 0.02°). Photometric stereo, which ignores the highlight: mean 0.4°.
  EXPECT_LE(ceres["median_deg"].get<double>(), 0.3) << ceres.dump();
  EXPECT_LE(ceres["p90_deg"].get<double>(), 1.0) << ceres.dump();
  EXPECT_LT(lambert["mean_deg"].get<double>(), 2.0) << lambert.dump();
  EXPECT_GT(lambert["mean_deg"].get<double>(), ceres["mean_deg"].get<double>()) << lambert.dump() << ceres.dump();
  // No tilt band worse than the Lambertian fit's by more than 0.25°: measured, the band of the
  // highlight (40–50°) is the one where GD10's is worse, 0.12° against 0.05°.
  ASSERT_EQ(ceres["by_tilt"].size(), lambert["by_tilt"].size());
  for (size_t b = 0; b < ceres["by_tilt"].size(); ++b) {
    EXPECT_LE(ceres["by_tilt"][b]["mean_deg"].get<double>(), lambert["by_tilt"][b]["mean_deg"].get<double>() + 0.25)
        << "band " << b << ": " << ceres.dump();
  }
}

TEST_F(ImportCommandTest, ANoisyCylinderIsFittedAsWellAsPhotometricStereoFitsIt) {
  CaptureAndImport("cylinder", "--noise 0.01 --sigma 0.25");
  const nlohmann::json lambert = FitAndScoreNormals("lambert");
  const nlohmann::json refine = FitAndScoreNormals("refine");
  // A cylinder's normals span a plane: its lights cannot be re-estimated, and are kept.
  EXPECT_NE(fit_output_.find("lights as given: their normals span too little"), std::string::npos) << fit_output_;
  EXPECT_LT(refine["mean_deg"].get<double>(), 1.5) << refine.dump();
  EXPECT_LE(refine["mean_deg"].get<double>(), lambert["mean_deg"].get<double>()) << refine.dump() << lambert.dump();
}

TEST_F(ImportCommandTest, AnOutOfModelSphereIsFittedNoWorseThanPhotometricStereoInAnyTiltBand) {
  // A GGX coat and mesostructure GD10 cannot represent. Where no light's half-vector reaches a
  // pixel's normal, a free fit tilts the normal to put Ward's lobe where the coat's highlight
  // lies; those pixels keep photometric stereo's normal (measured on 32 × 32 px, 24 lights:
  // mean 0.40° against photometric stereo's 1.03°, each band beyond 30° of tilt equal to its).
  CaptureAndImport("sphere", "--out-of-model --noise 0.02");
  const nlohmann::json lambert = FitAndScoreNormals("lambert");
  const nlohmann::json ceres = FitAndScoreNormals("ceres");
  EXPECT_LT(ceres["mean_deg"].get<double>(), 0.6) << ceres.dump();
  EXPECT_GT(Json("fit-ceres/fit.json")["pixels_normal_held"].get<int>(), 0);
  ASSERT_EQ(ceres["by_tilt"].size(), lambert["by_tilt"].size());
  for (size_t b = 0; b < ceres["by_tilt"].size(); ++b) {
    EXPECT_LE(ceres["by_tilt"][b]["mean_deg"].get<double>(), lambert["by_tilt"][b]["mean_deg"].get<double>() + 0.02)
        << "band " << b << ": " << ceres.dump() << lambert.dump();
  }
}

TEST_F(ImportCommandTest, ADomesMiscalibratedLightsAreReEstimatedAndItsNormalsComeOutNearerTheTruth) {
  // The files' directions off by |N(0, 1.5°)| and intensities by N(1, 0.03), as a real dome's
  // calibration errs. Measured on 48 × 48 px, 48 lights: the stack's lights as they are 0.785°, one
  // round of re-estimated lights 0.670°, two (the default) 0.596° (the lights turned 0.62° on
  // average).
  CaptureAndImport("sphere", "--noise 0.01 --light-error-deg 1.5 --intensity-error 0.03", 48, 48);
  const nlohmann::json as_given = FitAndScoreNormals("ceres", "--light-rounds 0", "as-given");
  const nlohmann::json refined = FitAndScoreNormals("ceres");
  EXPECT_NE(fit_output_.find("lights re-estimated from the fit"), std::string::npos) << fit_output_;
  EXPECT_LT(refined["mean_deg"].get<double>(), 0.85 * as_given["mean_deg"].get<double>()) << refined.dump() << as_given.dump();
  EXPECT_TRUE(Json("fit-as-given/fit.json")["light_refinement"].is_null());
  const nlohmann::json lights = Json("fit-ceres/fit.json")["light_refinement"];
  ASSERT_EQ(lights["lights"].size(), 48u) << lights.dump();
  EXPECT_GT(lights["mean_turn_deg"].get<double>(), 0.2) << lights.dump();

  // A flash capture's point lights are not what the errors model: refused, naming the option.
  const auto flash = RunCommand(Loom("sim capture --layout flash --size 8 --light-error-deg 1 --out " + Path("flash")));
  EXPECT_NE(flash.exit_code, 0);
  EXPECT_NE(flash.output.find("light_error_deg"), std::string::npos) << flash.output;
  EXPECT_FALSE(fs::exists(Path("flash")));
}

TEST_F(ImportCommandTest, ALightDomesSrgbJpegsAreImportedAndFittedNoWorseThanPhotometricStereoInAnyTiltBand) {
  // The lp layout: a .lp file and 8-bit sRGB JPEGs, whose quantisation and compression cost
  // accuracy (measured on 32 × 32 px, 24 lights: ceres mean 0.93° against photometric stereo's
  // 1.18°; noise-free 16-bit PNGs give 0.02°).
  const auto capture = RunCommand(Loom("sim capture --layout lp --size 32 --lights 24 --truth " + Path("truth.exr") +
                                       " --normals " + Path("normals.exr") + " --out " + Path("capture")));
  ASSERT_EQ(capture.exit_code, 0) << capture.output;
  ASSERT_TRUE(fs::exists(dir_ / "capture" / "capture.lp"));
  const auto imported = RunCommand(Loom("import " + Path("capture") + " --scale 1 --out " + Path("stack.exr")));
  ASSERT_EQ(imported.exit_code, 0) << imported.output;
  EXPECT_NE(imported.output.find("imported 24 images (lp, srgb)"), std::string::npos) << imported.output;
  const nlohmann::json lambert = FitAndScoreNormals("lambert");
  const nlohmann::json ceres = FitAndScoreNormals("ceres");
  EXPECT_LT(ceres["mean_deg"].get<double>(), 1.5) << ceres.dump();
  EXPECT_LT(ceres["mean_deg"].get<double>(), lambert["mean_deg"].get<double>()) << ceres.dump() << lambert.dump();
  ASSERT_EQ(ceres["by_tilt"].size(), lambert["by_tilt"].size());
  for (size_t b = 0; b < ceres["by_tilt"].size(); ++b) {
    EXPECT_LE(ceres["by_tilt"][b]["mean_deg"].get<double>(), lambert["by_tilt"][b]["mean_deg"].get<double>() + 0.02)
        << "band " << b << ": " << ceres.dump() << lambert.dump();
  }
}

TEST_F(ImportCommandTest, AHeldOutViewScoresTheFitAndTheMaskedMapsExport) {
  const auto capture = RunCommand(Loom("sim capture --size 24 --lights 16 --out " + Path("capture")));
  ASSERT_EQ(capture.exit_code, 0) << capture.output;
  const auto imported = RunCommand(
      Loom("import " + Path("capture") + " --hold-out 5 --held-out " + Path("held.exr") + " --out " + Path("train.exr")));
  ASSERT_EQ(imported.exit_code, 0) << imported.output;
  const double ceres = HeldOutL1("ceres");
  const double lambert = HeldOutL1("lambert");
  // Noise-free GD10 with a highlight: the lobe predicts the view it never saw; Lambert cannot.
  EXPECT_LT(ceres, 0.05);
  EXPECT_LT(ceres, 0.5 * lambert) << ceres << " " << lambert;
  // Maps with skipped (NaN) pixels export, the mask black.
  const auto exported =
      RunCommand(Loom("export " + Path("ceres/svbrdf.exr") + " --axf " + Path("m.axf") + " --gltf " + Path("gltf")));
  ASSERT_EQ(exported.exit_code, 0) << exported.output;
  EXPECT_NE(exported.output.find("written black"), std::string::npos) << exported.output;
}

TEST_F(ImportCommandTest, AFlashCaptureOfFewViewsIsFittedNoWorseThanALambertianSurfaceOnAViewLeftOut) {
  // A fabric under a phone's flash 0.8 cm beside the lens, which the files do not say: six views.
  const auto capture = RunCommand(
      Loom("sim capture --layout flash --size 32 --images 6 --truth " + Path("truth.exr") + " --out " + Path("capture")));
  ASSERT_EQ(capture.exit_code, 0) << capture.output;
  const auto imported = RunCommand(Loom("import " + Path("capture") + " --scale 1 --hold-out 2 --held-out " + Path("held.exr") +
                                        " --out " + Path("train.exr")));
  ASSERT_EQ(imported.exit_code, 0) << imported.output;
  EXPECT_NE(imported.output.find("imported 6 images (flash, gamma:2.2)"), std::string::npos) << imported.output;
  EXPECT_NE(imported.output.find("estimated from the highlights of"), std::string::npos) << imported.output;
  const double l1[2] = {HeldOutL1("ceres"), HeldOutL1("lambert")};
  // Five views left to fit: the pixels chose their model by the views left out of their fits.
  const nlohmann::json selection = Json("ceres/fit.json")["left_out_view_selection"];
  EXPECT_EQ(selection["views"].get<int>(), 5) << selection.dump();
  const nlohmann::json fit = Json("ceres/fit.json");
  EXPECT_EQ(selection["pixels_gd10"].get<int>() + selection["pixels_lambert"].get<int>(), fit["pixels_fitted"].get<int>())
      << selection.dump();
  // The Lambertian model was chosen for the stack by the same views: here the geometric normal,
  // since photometric stereo's normals tilt to mimic the flash's highlight.
  const nlohmann::json lambertian = selection["lambertian"];
  EXPECT_EQ(lambertian["pixels_photometric_stereo"].get<int>(), 0) << selection.dump();
  EXPECT_GT(lambertian["pixels_geometric_normal"].get<int>(), 0) << selection.dump();
  // The free GD10 fit predicted the views left out of it worse than the Lambertian surface did
  // (measured on such fabrics: 2–6× worse); the choice is no worse than photometric stereo on the
  // view this test held out (measured 0.86×; 1.01× with photometric stereo's normals kept).
  EXPECT_LE(l1[0], l1[1]) << "ceres " << l1[0] << ", lambert " << l1[1];
}

TEST_F(ImportCommandTest, AFolderWithoutALayoutOrWithABadHoldOutIsRefusedNamingIt) {
  fs::create_directories(dir_ / "empty");
  const auto none = RunCommand(Loom("import " + Path("empty") + " --out " + Path("s.exr")));
  EXPECT_EQ(none.exit_code, 1) << none.output;
  EXPECT_NE(none.output.find("empty"), std::string::npos) << none.output;
  EXPECT_NE(none.output.find("no layout recognised"), std::string::npos) << none.output;
  const auto capture = RunCommand(Loom("sim capture --size 8 --lights 4 --out " + Path("capture")));
  ASSERT_EQ(capture.exit_code, 0) << capture.output;
  const auto beyond =
      RunCommand(Loom("import " + Path("capture") + " --hold-out 4 --held-out " + Path("h.exr") + " --out " + Path("s.exr")));
  EXPECT_EQ(beyond.exit_code, 1) << beyond.output;
  EXPECT_NE(beyond.output.find("images 0 to 3"), std::string::npos) << beyond.output;
  EXPECT_FALSE(fs::exists(dir_ / "s.exr"));
}

// core/output_file.h's rule at a command: a re-run replaces what loom wrote, a file it did not
// write is kept unless --force, and a JSON report carries the marker that lets a re-run replace it.
TEST_F(ImportCommandTest, AReRunReplacesItsOwnOutputsAndAnotherFileOnlyWhenForced) {
  const auto capture = RunCommand(Loom("sim capture --size 8 --lights 4 --out " + Path("capture")));
  ASSERT_EQ(capture.exit_code, 0) << capture.output;
  const std::string import = "import " + Path("capture") + " --out " + Path("s.exr") + " --json " + Path("import.json");
  ASSERT_EQ(RunCommand(Loom(import)).exit_code, 0);
  EXPECT_TRUE(Json("import.json").contains("loom_version"));
  const auto again = RunCommand(Loom(import));
  EXPECT_EQ(again.exit_code, 0) << again.output;

  std::ofstream(dir_ / "notes.json") << "{\"mine\": true}\n";
  const std::string onto_notes = "import " + Path("capture") + " --out " + Path("t.exr") + " --json " + Path("notes.json");
  const auto refused = RunCommand(Loom(onto_notes));
  EXPECT_EQ(refused.exit_code, 1) << refused.output;
  EXPECT_NE(refused.output.find("--json " + Path("notes.json") + ": exists and is not a file loom wrote"), std::string::npos)
      << refused.output;
  EXPECT_FALSE(fs::exists(dir_ / "t.exr")) << "a refused output leaves the others unwritten";
  EXPECT_TRUE(Json("notes.json").contains("mine"));
  const auto forced = RunCommand(Loom(onto_notes + " --force"));
  EXPECT_EQ(forced.exit_code, 0) << forced.output;
  EXPECT_TRUE(Json("notes.json").contains("loom_version"));
}

}  // namespace
