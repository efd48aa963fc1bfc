// A progress bar on stderr for long renders: samples done, rate and time left.
#pragma once
#include <chrono>
#include <cstdint>
#include <string>

namespace basalt {

/// Draws a one-line progress bar on stderr once a render has run longer than a second.
class ProgressBar {
 public:
  /// \param total_samples pixel samples of the whole render; \param quiet draws nothing.
  ProgressBar(std::uint64_t total_samples, bool quiet);
  /// \brief Reports the fraction of the render done (0..1); redraws at most 10 times a second.
  void update(double fraction);
  /// \brief Starts the clock again (at the first sample, so that set-up is not in the
  ///        rate or the time left).
  void restart();
  /// \brief Ends the line if anything was drawn.
  void finish();

 private:
  std::uint64_t total_;
  bool quiet_;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point start_, last_;
};

}  // namespace basalt
