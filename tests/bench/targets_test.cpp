// The benchmark's issue 12 targets table (tests/bench/targets.h): family names, which rows a
// run's figures give, their ratios and whether each is met. Built into basalt_cpu_tests outside
// the sanitizer build (it links Google Benchmark).
#include <gtest/gtest.h>

#include <sstream>

#include "bench/targets.h"

namespace basalt::bench {
namespace {

TEST(BenchTargets, FamilyNameDropsRunParameters) {
  EXPECT_EQ(family_name("rays/igea/camera/gpu/iterations:1/real_time"), "rays/igea/camera/gpu");
  EXPECT_EQ(family_name("memory/igea-infinite/cpu/iterations:1/repeats:1/manual_time"),
            "memory/igea-infinite/cpu");
  EXPECT_EQ(family_name("specialisation/cornell-box/config:2/iterations:1/real_time"),
            "specialisation/cornell-box");
  EXPECT_EQ(family_name("gpu/cornell-box"), "gpu/cornell-box");
}

TEST(BenchTargets, RowsRatiosAndVerdicts) {
  Figures f;
  f["equal-error/spheres-lights/lavapipe"] = {{"basalt_s", 1.5}, {"pbrt_s", 2.0}, {"vs_pbrt", 0.75}};
  f["equal-error/spheres-lights/cpu"] = {{"basalt_s", 0.6}, {"pbrt_s", 2.0}, {"vs_pbrt", 0.3}};
  f["gpu/cornell-box"] = {{"samples/s", 2.0e5}, {"vs_cpu", 0.5}};
  f["rays/igea/camera/gpu"] = {{"Mrays/s", 4.9}};
  f["rays/igea/camera/cpu"] = {{"Mrays/s", 7.0}};
  f["rays/igea/camera/embree"] = {{"Mrays/s", 14.0}};
  f["rays/igea/bounce/gpu"] = {{"Mrays/s", 5.5}};
  f["pipeline/cornell-box/cold"] = {{"pipeline_s", 0.7}, {"first_pass_s", 0.75}};
  f["pipeline/material-zoo/warm"] = {{"pipeline_s", 1.3}, {"first_pass_s", 1.4}};
  f["memory/igea-infinite/lavapipe"] = {
      {"peak_MiB", 180}, {"tables_MiB", 25}, {"above_baseline_vs_tables", 1.6}};
  f["memory/cornell-box/lavapipe"] = {
      {"peak_MiB", 107}, {"tables_MiB", 1}, {"above_baseline_vs_tables", 0.0}};
  const std::vector<TargetRow> rows = target_rows(f);
  std::map<std::string, TargetRow> by;
  for (const auto& r : rows) by[r.target] = r;
  // The CPU reference's equal-error row and the small scene's memory row are not targets.
  ASSERT_EQ(rows.size(), 9u);
  const TargetRow& eq = by.at("equal error vs pbrt-v4, spheres-lights, lavapipe");
  EXPECT_DOUBLE_EQ(eq.ratio, 0.75);
  EXPECT_TRUE(eq.met());
  EXPECT_EQ(eq.anchor, "pbrt-v4 2 s");
  const TargetRow& vs = by.at("samples/s vs CPU reference, cornell-box, lavapipe");
  EXPECT_FALSE(vs.met());
  EXPECT_EQ(vs.anchor, "CPU ref. 0.4 M/s");
  EXPECT_FALSE(by.at("Igea camera rays, lavapipe (M/s)").met());
  EXPECT_TRUE(by.at("Igea bounce rays, lavapipe (M/s)").met());  // 5.5 >= 5
  const TargetRow& emb = by.at("Igea camera rays, CPU reference vs Embree");
  EXPECT_DOUBLE_EQ(emb.ratio, 0.5);
  EXPECT_TRUE(emb.met());
  EXPECT_TRUE(by.at("pipeline cold, cornell-box").met());
  EXPECT_FALSE(by.at("first pass cold, cornell-box").met());
  EXPECT_FALSE(by.at("pipeline warm, material-zoo").met());
  EXPECT_TRUE(by.at("(peak - baseline) / tables, igea-infinite, lavapipe").met());
  std::ostringstream out;
  print_targets(rows, out);
  EXPECT_NE(out.str().find("5 of 9 targets met"), std::string::npos) << out.str();
}

}  // namespace
}  // namespace basalt::bench
