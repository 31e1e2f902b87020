// The evaluation's summary.json as loom demo reads it back, and the methods' table it prints.
#include "fitting/report/report.h"

#include <gtest/gtest.h>

#include <sstream>

namespace loom::fitting {
namespace {

Evaluation SomeEvaluation(double scale) {
  Evaluation e;
  e.parameters = {{"a_d", 0.05 * scale}, {"n_s", 0.1}, {"sigma", 0.12 * scale}};
  e.normal_median_deg = 4.5 * scale;
  e.normal_p90_deg = 9.25;
  e.map_noise = {{"a_s", 2.0 * scale, 1.0}};
  e.fit_vs_measured = {{"linear", 100, 0.2 * scale}, {"all", 300, 0.15 * scale}};
  return e;
}

TEST(ReportTest, TheMethodsTableHasOneRowPerMethodInOrderWithItsNumbers) {
  nlohmann::ordered_json methods;
  methods["cnn"] = nlohmann::ordered_json::parse(EvaluationJson(SomeEvaluation(2)));
  methods["cnn+refine"] = nlohmann::ordered_json::parse(EvaluationJson(SomeEvaluation(1)));
  std::ostringstream table;
  PrintEvaluationTable(table, methods);
  const std::string text = table.str();
  // The header names the parameters (not the normal's components) and the render groups.
  EXPECT_NE(text.find("a_d"), std::string::npos) << text;
  EXPECT_NE(text.find("sigma"), std::string::npos) << text;
  EXPECT_EQ(text.find("n_s"), std::string::npos) << text;
  EXPECT_NE(text.find("linear"), std::string::npos) << text;
  const size_t cnn = text.find("\ncnn "), refine = text.find("\ncnn+refine");
  ASSERT_NE(cnn, std::string::npos) << text;
  ASSERT_NE(refine, std::string::npos) << text;
  EXPECT_LT(cnn, refine);
  const std::string refine_row = text.substr(refine);
  for (const char* value : {"4.5", "9.2", "0.050", "0.120", "0.200", "0.150", "2.00"}) {
    EXPECT_NE(refine_row.find(value), std::string::npos) << value << " in " << refine_row;
  }
  EXPECT_NE(text.substr(cnn, refine - cnn).find("0.100"), std::string::npos) << text;  // a_d 0.05 × 2
  std::ostringstream nothing;
  PrintEvaluationTable(nothing, nlohmann::ordered_json::object());
  EXPECT_TRUE(nothing.str().empty());
}

}  // namespace
}  // namespace loom::fitting
