// A progress bar on stderr for long renders: samples done, rate and time left.
#include "util/progress.h"

#include <algorithm>
#include <cstdio>

namespace basalt {

ProgressBar::ProgressBar(std::uint64_t total_samples, bool quiet)
    : total_(total_samples), quiet_(quiet) {
  start_ = last_ = std::chrono::steady_clock::now();
}

void ProgressBar::restart() { start_ = last_ = std::chrono::steady_clock::now(); }

void ProgressBar::update(double fraction) {
  if (quiet_ || !(fraction >= 0.0)) return;  // NaN (an empty render) draws nothing
  fraction = std::min(fraction, 1.0);
  auto now = std::chrono::steady_clock::now();
  double elapsed = std::chrono::duration<double>(now - start_).count();
  if (elapsed < 1.0) return;  // short renders show no bar
  if (drawn_ && fraction < 1.0 && std::chrono::duration<double>(now - last_).count() < 0.1) return;
  last_ = now;
  drawn_ = true;
  const int width = 30;
  int filled = int(fraction * width + 0.5);
  double done = fraction * double(total_);
  double rate = done / elapsed;
  double left = fraction > 0 ? elapsed * (1.0 - fraction) / fraction : 0.0;
  std::fprintf(stderr, "\r[%.*s%*s] %5.1f%%  %.3g / %.3g samples  %.3g Msamples/s  %.0f s left ",
               filled, "##############################", width - filled, "", 100.0 * fraction,
               done, double(total_), rate * 1e-6, left);
  std::fflush(stderr);
}

void ProgressBar::finish() {
  if (drawn_) std::fprintf(stderr, "\n");
  drawn_ = false;
}

}  // namespace basalt
