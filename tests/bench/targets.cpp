// The issue 12 targets table (tests/bench/targets.h).
#include "bench/targets.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>

namespace basalt::bench {
namespace {

/// \p v with \p digits significant digits and \p unit, e.g. "4.91 M/s".
std::string num(double v, const char* unit = "", int digits = 3) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g%s%s", digits, v, *unit ? " " : "", unit);
  return buf;
}

/// The part of a family name after \p prefix up to the next '/', and the rest after it.
std::pair<std::string, std::string> split_after(const std::string& name, const std::string& prefix) {
  const std::string rest = name.substr(prefix.size());
  const auto slash = rest.find('/');
  if (slash == std::string::npos) return {rest, ""};
  return {rest.substr(0, slash), rest.substr(slash + 1)};
}

/// Counter \p key of benchmark \p name, or NAN when either is missing.
double figure(const Figures& f, const std::string& name, const std::string& key) {
  const auto it = f.find(name);
  if (it == f.end()) return NAN;
  const auto c = it->second.find(key);
  return c == it->second.end() ? NAN : c->second;
}

/// Smallest tables (MiB) for which the memory ratio is a target row: below it the peak is the
/// driver compiling the pipeline, not the tables (docs/performance.md, "Peak memory").
constexpr double kMemoryRowMinMiB = 4.0;

}  // namespace

std::string family_name(const std::string& run_name) {
  std::string out;
  std::size_t start = 0;
  while (start <= run_name.size()) {
    const std::size_t slash = std::min(run_name.find('/', start), run_name.size());
    const std::string part = run_name.substr(start, slash - start);
    if (part.find(':') != std::string::npos || part == "real_time" || part == "manual_time")
      break;
    out += (out.empty() ? "" : "/") + part;
    start = slash + 1;
  }
  return out;
}

TargetsReporter::TargetsReporter(std::unique_ptr<benchmark::BenchmarkReporter> inner)
    : inner_(std::move(inner)) {}

bool TargetsReporter::ReportContext(const Context& context) {
  inner_->SetOutputStream(&GetOutputStream());
  inner_->SetErrorStream(&GetErrorStream());
  return inner_->ReportContext(context);
}

void TargetsReporter::ReportRuns(const std::vector<Run>& runs) {
  inner_->ReportRuns(runs);
  for (const Run& r : runs) {
    if (r.error_occurred) continue;
    const bool median = r.run_type == Run::RT_Aggregate && r.aggregate_name == "median";
    const bool single = r.run_type == Run::RT_Iteration && r.repetitions <= 1;
    if (!median && !single) continue;
    auto& out = figures_[family_name(r.run_name.str())];
    for (const auto& [key, counter] : r.counters) out[key] = counter.value;
  }
}

void TargetsReporter::Finalize() { inner_->Finalize(); }

std::vector<TargetRow> target_rows(const Figures& f) {
  const char* env_device = std::getenv("BASALT_BENCH_DEVICE");
  const std::string device = env_device && *env_device ? env_device : "lavapipe";
  std::vector<TargetRow> rows;
  // Equal error against pbrt-v4 (tests/bench/anchors.cpp).
  for (const auto& [name, c] : f) {
    if (name.rfind("equal-error/", 0) != 0) continue;
    const auto [scene, dev] = split_after(name, "equal-error/");
    if (dev != "lavapipe") continue;  // the CPU reference's rows are for scale, not a target
    rows.push_back({"equal error vs pbrt-v4, " + scene + ", lavapipe",
                    num(figure(f, name, "basalt_s"), "s"),
                    "pbrt-v4 " + num(figure(f, name, "pbrt_s"), "s"),
                    figure(f, name, "vs_pbrt"), true, 0.8});
  }
  // Samples/s against the CPU reference on every scene (bench.cpp BM_Gpu).
  for (const auto& [name, c] : f) {
    if (name.rfind("gpu/", 0) != 0) continue;
    const double rate = figure(f, name, "samples/s"), vs = figure(f, name, "vs_cpu");
    rows.push_back({"samples/s vs CPU reference, " + name.substr(4) + ", " + device,
                    num(rate * 1e-6, "M/s"), "CPU ref. " + num(rate / vs * 1e-6, "M/s"), vs,
                    false, 1.0});
  }
  // Igea rays (tests/bench/rays.cpp): lavapipe's rate, and the CPU reference against Embree.
  for (const char* set : {"camera", "bounce", "shadow"}) {
    const std::string base = std::string("rays/igea/") + set;
    const double gpu = figure(f, base + "/gpu", "Mrays/s");
    const double cpu = figure(f, base + "/cpu", "Mrays/s");
    const double embree = figure(f, base + "/embree", "Mrays/s");
    const double wanted = std::string(set) == "camera" ? 10.0 : 5.0;
    if (gpu == gpu)
      rows.push_back({std::string("Igea ") + set + " rays, " + device + " (M/s)",
                      num(gpu, "M/s"), "", gpu, false, wanted});
    if (cpu == cpu && embree == embree)
      rows.push_back({std::string("Igea ") + set + " rays, CPU reference vs Embree",
                      num(cpu, "M/s"), "Embree " + num(embree, "M/s"), cpu / embree, false, 0.5});
  }
  // Pipeline creation and the first pass, as the command sees them (bench.cpp
  // BM_PipelineProcess).
  for (const auto& [name, c] : f) {
    if (name.rfind("pipeline/", 0) != 0) continue;
    const auto [scene, kind] = split_after(name, "pipeline/");
    const bool cold = kind == "cold";
    const double s = figure(f, name, "pipeline_s");
    rows.push_back({"pipeline " + kind + ", " + scene, num(s, "s"), "", s, true, cold ? 2.0 : 0.3});
    if (cold && scene == "cornell-box") {
      const double first = figure(f, name, "first_pass_s");
      rows.push_back({"first pass cold, " + scene, num(first, "s"), "", first, true, 0.5});
    }
  }
  // Peak memory against the tables (anchors.cpp BM_Memory), where the tables are large enough.
  for (const auto& [name, c] : f) {
    if (name.rfind("memory/", 0) != 0) continue;
    if (!(figure(f, name, "tables_MiB") >= kMemoryRowMinMiB)) continue;
    const auto [scene, dev] = split_after(name, "memory/");
    rows.push_back({"(peak - baseline) / tables, " + scene + ", " + dev,
                    num(figure(f, name, "peak_MiB"), "MiB"),
                    "tables " + num(figure(f, name, "tables_MiB"), "MiB"),
                    figure(f, name, "above_baseline_vs_tables"), true, 2.0});
  }
  return rows;
}

void print_targets(const std::vector<TargetRow>& rows, std::ostream& out) {
  if (rows.empty()) return;
  std::size_t width = 6;
  for (const auto& r : rows) width = std::max(width, r.target.size());
  char line[512];
  out << "\nIssue 12 targets (medians where repeated; memory rows for tables of at least "
      << kMemoryRowMinMiB << " MiB)\n";
  std::snprintf(line, sizeof line, "%-*s  %-12s  %-20s  %8s  %8s  %s\n", int(width), "target",
                "figure", "anchor", "ratio", "wanted", "met");
  out << line;
  int met = 0;
  for (const auto& r : rows) {
    const std::string wanted = std::string(r.at_most ? "<= " : ">= ") + num(r.bound);
    std::snprintf(line, sizeof line, "%-*s  %-12s  %-20s  %8s  %8s  %s\n", int(width),
                  r.target.c_str(), r.figure.c_str(), r.anchor.c_str(), num(r.ratio).c_str(),
                  wanted.c_str(), r.met() ? "yes" : "no");
    out << line;
    met += r.met() ? 1 : 0;
  }
  out << met << " of " << rows.size() << " targets met\n";
}

}  // namespace basalt::bench
