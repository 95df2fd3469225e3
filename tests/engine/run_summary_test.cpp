// A run's summary (engine/runtime/run_summary.h) from figures chosen by
// hand: the percentiles, the frames over the frame time, the stage split
// and the broadphase's share, the speed-up and its spread, the table.
#include "engine/runtime/run_summary.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "engine/runtime/statistics.h"

namespace overlap::engine {
namespace {

TEST(Statistics, PercentilesInterpolateBetweenOrderStatistics) {
  const std::vector<double> values = {5, 1, 4, 2, 3};  // 1..5, shuffled
  EXPECT_DOUBLE_EQ(percentile(values, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(percentile(values, 0.5), median(values));
  EXPECT_DOUBLE_EQ(percentile(values, 0.95), 4.8);
  EXPECT_DOUBLE_EQ(percentile(values, 1.0), 5.0);
  EXPECT_DOUBLE_EQ(percentile({}, 0.95), 0.0);
  EXPECT_DOUBLE_EQ(percentile({7}, 0.99), 7.0);
}

TEST(Statistics, TheSpreadIsMedianP95P99AndMax) {
  std::vector<double> values;
  for (int i = 1; i <= 100; ++i) values.push_back(i);
  const FrameSpread spread = spreadOf(values);
  EXPECT_DOUBLE_EQ(spread.median, 50.5);
  EXPECT_DOUBLE_EQ(spread.p95, 95.05);
  EXPECT_DOUBLE_EQ(spread.p99, 99.01);
  EXPECT_DOUBLE_EQ(spread.max, 100.0);
  EXPECT_EQ(countOver(values, 90.0), 10);
  EXPECT_EQ(countOver(values, 100.0), 0);  // over, not at
}

physics::FrameTimings stages(double update, double broadphase, double narrowphase, double solver,
                             double total) {
  physics::FrameTimings timings;
  timings.update_ms = update;
  timings.broadphase_ms = broadphase;
  timings.narrowphase_ms = narrowphase;
  timings.solver_ms = solver;
  timings.total_ms = total;
  return timings;
}

TEST(FrameSummary, SaysTheSpreadTheFramesOverAndEachStagesShare) {
  FrameSummary summary(1.0 / 30);
  // Frames of 20, 40, 40 and 60 ms; a step of 10 ms: update 1, broadphase
  // 2, narrowphase 3, solver 3 and 1 ms of nothing named.
  for (const double frame : {20.0, 40.0, 40.0, 60.0}) summary.add(frame, stages(1, 2, 3, 3, 10));
  EXPECT_EQ(summary.frames(), 4);
  EXPECT_EQ(summary.framesOverFrameTime(), 3);
  const std::vector<std::string> lines = summary.lines();
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_NE(lines[0].find("median 40.0 ms, p95 57.0, p99 59.4, max 60.0"), std::string::npos)
      << lines[0];
  EXPECT_NE(lines[0].find("3 of 4 over the frame time (33.3 ms)"), std::string::npos) << lines[0];
  EXPECT_NE(lines[1].find("10.0 ms a frame (means): update 1.00 (10%), broadphase 2.00 (20%), "
                          "narrowphase 3.00 (30%), solver 3.00 (30%), integrate 0.00 (0.0%), "
                          "ccd query 0.00 (0.0%), other 1.00 (10%)"),
            std::string::npos)
      << lines[1];
  // The broadphase against the whole frame (a mean of 40 ms), not the step.
  EXPECT_NE(lines[2].find("2.00 ms of the mean frame's 40.0 (5.0%); with the update 3.00 ms "
                          "(7.5%)"),
            std::string::npos)
      << lines[2];
}

TEST(FrameSummary, ARunOfNoFramesSaysSoWithoutDividingByZero) {
  const FrameSummary summary(1.0 / 30);
  const std::vector<std::string> lines = summary.lines();
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_NE(lines[0].find("0 of 0 over"), std::string::npos) << lines[0];
  for (const std::string& line : lines) EXPECT_EQ(line.find("nan"), std::string::npos) << line;
}

TEST(Speedup, IsTheRatioOfMediansWithTheQuartilesOfTheFramesRatios) {
  // Frame by frame the sync run takes 2, 1, 3 and 1.5 times the async one.
  const Speedup speedup = speedupOf({20, 10, 30, 15}, {10, 10, 10, 10});
  EXPECT_DOUBLE_EQ(speedup.speedup, 17.5 / 10);
  EXPECT_DOUBLE_EQ(speedup.frames_q1, 1.375);
  EXPECT_DOUBLE_EQ(speedup.frames_median, 1.75);
  EXPECT_DOUBLE_EQ(speedup.frames_q3, 2.25);
}

TEST(AlignedTable, RightAlignsNumbersAndLeftAlignsNames) {
  const std::vector<std::string> lines =
      alignedTable({{"algo", "us"}, {"cpusap", "7.5"}, {"bf", "120.0"}, {"bvh", "-"}});
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0], "algo       us");
  EXPECT_EQ(lines[1], "cpusap    7.5");
  EXPECT_EQ(lines[2], "bf      120.0");
  EXPECT_EQ(lines[3], "bvh         -");
}

TEST(ThreeDigits, KeepsThreeSignificantDigitsWithoutAnExponent) {
  EXPECT_EQ(threeDigits(0.2134), "0.213");
  EXPECT_EQ(threeDigits(3.521), "3.52");
  EXPECT_EQ(threeDigits(35.14), "35.1");
  EXPECT_EQ(threeDigits(152.4), "152");
  EXPECT_EQ(threeDigits(15240), "15240");
  EXPECT_EQ(threeDigits(0), "0.00");
}

}  // namespace
}  // namespace overlap::engine
