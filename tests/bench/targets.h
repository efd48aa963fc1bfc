// The issue 12 targets table of the benchmark: a reporter that passes every run on to the usual
// display and keeps each benchmark's figures, and the table printed from them at the end.
#pragma once
#include <map>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

namespace basalt::bench {

/// Counters of one benchmark (its median over the repetitions, or its one run), by name.
using Figures = std::map<std::string, std::map<std::string, double>>;

/// Forwards every report to \p inner and keeps the figures of each benchmark under its family
/// name (the registered name without "/iterations:..", "/real_time" and the like).
class TargetsReporter : public benchmark::BenchmarkReporter {
 public:
  explicit TargetsReporter(std::unique_ptr<benchmark::BenchmarkReporter> inner);
  bool ReportContext(const Context& context) override;
  void ReportRuns(const std::vector<Run>& runs) override;
  void Finalize() override;
  /// What the runs reported so far.
  const Figures& figures() const { return figures_; }

 private:
  std::unique_ptr<benchmark::BenchmarkReporter> inner_;
  Figures figures_;
};

/// The family name of a run name: "rays/igea/camera/gpu/iterations:1/real_time" ->
/// "rays/igea/camera/gpu".
std::string family_name(const std::string& run_name);

/// One row of the targets table.
struct TargetRow {
  std::string target;  // what is measured, e.g. "Igea camera rays, lavapipe"
  std::string figure;  // the measured figure with its unit
  std::string anchor;  // what it is compared with, or empty
  double ratio = 0.0;  // the value compared with the wanted bound
  bool at_most = true; // wanted: ratio <= bound (else ratio >= bound)
  double bound = 0.0;
  bool met() const { return at_most ? ratio <= bound : ratio >= bound; }
};

/// \brief The rows of issue 12's targets that \p figures hold: equal error against pbrt-v4
///        (vs_pbrt <= 0.8), lavapipe against the CPU reference (vs_cpu >= 1), Igea rays on
///        lavapipe (10 M camera, 5 M secondary rays/s), the CPU reference against Embree (>=
///        0.5), pipeline creation (cold <= 2 s, warm <= 0.3 s, the Cornell box's first pass
///        cold <= 0.5 s) and peak memory ((peak - baseline) / tables <= 2).
std::vector<TargetRow> target_rows(const Figures& figures);

/// \brief Prints \p rows as a table with a met/not met column and a count.
void print_targets(const std::vector<TargetRow>& rows, std::ostream& out);

}  // namespace basalt::bench
