// `basalt study SCENE.pbrt`: what accuracy costs in time (issue 10). Every sweep point is a
// child run of this binary (posix_spawn, no shell) timed from outside; its image is scored
// against a reference with relMSE and SSIM (study/metrics.h); the results go to study.json and
// study.csv, and tools/study_report.py draws the charts and writes report.md.
#include "study/study.h"

#include <CLI/CLI.hpp>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <thread>

#include "image/image_io.h"
#include "scene/scene.h"
#include "study/metrics.h"
#include "util/cli_options.h"
#include "util/stats.h"

extern char** environ;

#include "basalt_version.h"  // BASALT_GIT_COMMIT: generated at build time (cmake/version.cmake)
#ifndef BASALT_SOURCE_DIR
#define BASALT_SOURCE_DIR "."
#endif

namespace basalt::study {

namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

const std::vector<Knob>& knobs() {
  // Settings besides the default; the default runs without the option. "scene" means the
  // scene file's own choice. Rows whose option the binary lacks are reported, not run.
  static const std::vector<Knob> table = {
      {"spp", "--spp", {}, "", "image"},  // the x-axis: powers of 2 up to --spp-max
      {"maxdepth", "--maxdepth", {"1", "2", "3", "5", "8"}, "scene", "image"},
      {"roulette", "--roulette", {"off", "3"}, "pbrt-v4", "image"},
      {"mis", "--mis", {"balance", "bsdf", "light"}, "power", "image"},
      {"mix", "--mix", {"stochastic", "weighted"}, "auto", "image"},
      {"texture-filter", "--texture-filter", {"point", "bilinear", "trilinear", "ewa"}, "scene",
       "image"},
      {"noise-octaves", "--noise-octaves", {"1", "2", "4"}, "0", "image"},  // 0: no cap
      {"noise-precision", "--noise-precision", {"fp32"}, "split", "image"},
      {"bump-differences", "--bump-differences", {"central"}, "forward", "image"},
      {"bump-dndu", "--bump-dndu", {"off"}, "on", "image"},
      {"sampler", "--sampler",
       {"independent", "stratified", "halton", "paddedsobol", "zsobol", "sobol", "pmj02bn"},
       "scene", "image"},
      {"light-sampler", "--light-sampler", {"exhaustive", "power", "uniform"}, "scene", "image"},
      {"pipeline", "--pipeline", {"all"}, "specialised", "time"},
      {"bvh-bins", "--bvh-bins", {"4", "16"}, "32", "time"},
      {"bvh-leaf", "--bvh-leaf", {"2", "16"}, "8", "time"},
      {"coated-nsamples", "--coated-nsamples", {"1", "4", "16"}, "scene", "image"},
      {"coated-maxdepth", "--coated-maxdepth", {"1", "3", "30"}, "scene", "image"},
      {"layered-mis", "--layered-mis", {"pbrt-v4"}, "basalt", "image"},
  };
  return table;
}

namespace {

constexpr int kExitInput = 1, kExitUsage = 2;

/// True if \p help (basalt --help output) documents \p option as a whole word.
bool help_has_option(const std::string& help, const std::string& option) {
  auto word = [](char c) { return std::isalnum((unsigned char)c) || c == '-' || c == '_'; };
  for (std::size_t at = help.find(option); at != std::string::npos;
       at = help.find(option, at + 1)) {
    const bool starts = at == 0 || !word(help[at - 1]);
    const std::size_t end = at + option.size();
    if (starts && (end == help.size() || !word(help[end]))) return true;
  }
  return false;
}

/// Seed of the reference render: far from the sweep's seeds 1..K, so that no point shares
/// its first samples with the reference.
constexpr long long kReferenceSeed = 7777777;
/// Exit code of tools/study_report.py when matplotlib cannot be imported.
constexpr int kReportNoMatplotlib = 3;

struct Options {
  std::string scene, out, reference, compare, compare_name, report_script;
  std::string python = "/usr/bin/python3";
  std::vector<std::string> knobs, devices = {"lavapipe", "cpu"};
  std::string reference_device;  // empty: the device predicted fastest
  double budget = 0.0;           // 0: unlimited
  double compare_time = 0.0;
  int spp_max = 64, seeds = 3, reference_spp = 0;  // 0: 16 x spp_max
  bool quiet = false, keep_images = false;
};

/// Seconds since \p t0.
double since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// The last \p lines lines of \p text (at most 600 characters), trimmed.
std::string tail(const std::string& text, int lines = 4) {
  std::size_t end = text.find_last_not_of(" \n\r\t");
  if (end == std::string::npos) return "";
  std::size_t at = end + 1;
  for (int i = 0; i < lines && at > 0; ++i) {
    const std::size_t nl = text.rfind('\n', at - 1);
    at = nl == std::string::npos ? 0 : nl;
    if (at == 0) break;
  }
  std::string t = text.substr(at, end + 1 - at);
  if (!t.empty() && t[0] == '\n') t.erase(0, 1);
  return t.size() > 600 ? t.substr(t.size() - 600) : t;
}

/// Whole contents of a file ("" if unreadable).
std::string read_text(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

/// FNV-1a 64-bit hash (Fowler, Noll, Vo) of \p bytes, continuing from \p h.
std::uint64_t fnv1a(const std::string& bytes, std::uint64_t h = 14695981039346656037ull) {
  for (unsigned char c : bytes) h = (h ^ c) * 1099511628211ull;
  return h;
}

/// A name safe in a file name: letters, digits, '.', '-' and '_'; others become '_'.
std::string file_safe(std::string s) {
  for (char& c : s)
    if (!std::isalnum((unsigned char)c) && c != '.' && c != '-' && c != '_') c = '_';
  return s;
}

/// The path of this executable (children run the same build).
std::string self_exe() {
  std::error_code ec;
  fs::path p = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw std::runtime_error("cannot read /proc/self/exe: " + ec.message());
  return p.string();
}

/// The CPU model from /proc/cpuinfo ("unknown" if absent).
std::string cpu_model() {
  std::istringstream in(read_text("/proc/cpuinfo"));
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) {
      std::size_t colon = line.find(':');
      if (colon != std::string::npos) return line.substr(line.find_first_not_of(" \t", colon + 1));
    }
  return "unknown";
}

/// What a child process did.
struct ChildResult {
  int exit_code = -1;     // -1: killed by a signal (or never started)
  bool stopped = false;   // killed by us at the deadline
  double seconds = 0.0;   // wall time from spawn to exit
  std::string error;      // tail of its stderr, or why it could not start
};

/// Runs \p args (args[0] is the executable) with stdout and stderr to the given files,
/// stdin from /dev/null; kills it at \p deadline; calls \p tick about 20 times a second.
ChildResult run_child(const std::vector<std::string>& args, const std::string& out_path,
                      const std::string& err_path, std::optional<Clock::time_point> deadline,
                      const std::function<void()>& tick) {
  ChildResult r;
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&fa, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&fa, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  const auto t0 = Clock::now();
  const int rc = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) {
    r.error = "cannot start " + args[0] + ": " + std::strerror(rc);
    return r;
  }
  int status = 0;
  for (;;) {
    const pid_t w = waitpid(pid, &status, WNOHANG);
    if (w == pid) break;
    if (w < 0 && errno != EINTR) {
      r.error = std::string("waitpid: ") + std::strerror(errno);
      return r;
    }
    if (deadline && Clock::now() >= *deadline && !r.stopped) {
      ::kill(pid, SIGKILL);  // our own child, by its id
      r.stopped = true;
    }
    if (tick) tick();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  r.seconds = since(t0);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (r.stopped)
    r.error = "stopped at the end of the time budget";
  else if (r.exit_code != 0)
    r.error = tail(read_text(err_path));
  if (r.exit_code != 0 && r.error.empty())
    r.error = WIFSIGNALED(status) ? "killed by signal " + std::to_string(WTERMSIG(status))
                                  : "exit " + std::to_string(r.exit_code);
  return r;
}

/// One configuration of the knobs: the default, or one knob at one non-default value.
struct Setting {
  std::string knob, value, kind;  // knob "default" for the default configuration
  std::vector<std::string> args;  // the option and value given to basalt
  /// Key of the time model and of file names.
  std::string key() const { return knob == "default" ? "default" : knob + "=" + value; }
};

/// One child render: a setting on a device at an spp with a seed.
struct Run {
  int point = 0, seed = 0;
  enum class State { Pending, Done, Failed, Skipped } state = State::Pending;
  double seconds_process = NAN, seconds_render = NAN, seconds_pipeline = NAN;
  double rel_mse = NAN, ssim_error = NAN, max_abs_diff = NAN;
  std::string id, image, stats, error, device_name;
  json quality;
};

/// A sweep point: a setting on a device at an spp, over the seeds.
struct Point {
  int setting = 0, spp = 0;
  std::string device;
  std::vector<int> runs;
};

/// Process time predicted from earlier runs: per device and setting, time = startup + rate * spp.
class TimeModel {
 public:
  /// Records a finished run.
  void add(const std::string& device, const std::string& setting, int spp, double process,
           double render) {
    obs_[device + "\n" + setting].push_back({double(spp), process, render});
    obs_[device].push_back({double(spp), process, render});
  }
  /// \brief Predicted process seconds, or nothing if the device has never run.
  std::optional<double> predict(const std::string& device, const std::string& setting,
                                int spp) const {
    auto dev = obs_.find(device);
    if (dev == obs_.end()) return std::nullopt;
    auto own = obs_.find(device + "\n" + setting);
    auto def = obs_.find(device + "\ndefault");
    // A setting not yet run is taken to cost what the default costs.
    const auto& o = own != obs_.end() ? own->second : def != obs_.end() ? def->second : dev->second;
    auto [startup, rate] = fit(o);
    return startup + rate * spp;
  }
  /// \brief (startup, seconds per spp) of a device and setting, if it has run.
  std::optional<std::pair<double, double>> startup_rate(const std::string& device,
                                                        const std::string& setting) const {
    auto it = obs_.find(device + "\n" + setting);
    if (it == obs_.end()) return std::nullopt;
    return fit(it->second);
  }

 private:
  struct Obs {
    double spp, process, render;
  };
  /// Startup = mean of (process - render), the time outside the render loop; rate = total
  /// render time over total samples (the runs' own render timers, not the noisy process times).
  static std::pair<double, double> fit(const std::vector<Obs>& o) {
    double startup = 0, render = 0, spp = 0;
    for (const auto& p : o) {
      startup += std::max(0.0, p.process - p.render) / double(o.size());
      render += p.render, spp += p.spp;
    }
    return {startup, render / spp};
  }
  std::map<std::string, std::vector<Obs>> obs_;
};

/// Mean and standard error (sample sd / sqrt(n)) of the finite values; NaN where undefined.
std::pair<double, double> mean_stderr(const std::vector<double>& v) {
  std::vector<double> f;
  for (double x : v)
    if (std::isfinite(x)) f.push_back(x);
  if (f.empty()) return {NAN, NAN};
  double m = 0;
  for (double x : f) m += x / double(f.size());
  if (f.size() < 2) return {m, NAN};
  double ss = 0;
  for (double x : f) ss += (x - m) * (x - m);
  return {m, std::sqrt(ss / double(f.size() - 1)) / std::sqrt(double(f.size()))};
}

/// Fit of relMSE = a / spp + c, least squares on relative residuals (each point weighted by
/// 1 / relMSE^2, so every decade of error counts alike); c is clamped to be >= 0.
struct ErrorFit {
  double a = NAN, c = NAN;
  int points = 0;
};

/// Fits ErrorFit to (spp, relMSE) pairs with finite, positive errors.
ErrorFit fit_error(const std::vector<std::pair<double, double>>& pts) {
  ErrorFit f;
  double s11 = 0, s12 = 0, s22 = 0, b1 = 0, b2 = 0;
  for (auto [spp, e] : pts) {
    if (!(e > 0) || !std::isfinite(e)) continue;
    const double w = 1.0 / (e * e), x = 1.0 / spp;
    s11 += w * x * x, s12 += w * x, s22 += w, b1 += w * x * e, b2 += w * e;
    ++f.points;
  }
  if (f.points == 0) return f;
  const double det = s11 * s22 - s12 * s12;
  if (f.points >= 2 && std::abs(det) > 1e-300) {
    f.a = (b1 * s22 - b2 * s12) / det;
    f.c = (s11 * b2 - s12 * b1) / det;
  }
  if (!(f.c >= 0) || !(f.a >= 0)) {  // one point, or a negative floor: the pure 1/spp curve
    f.c = 0;
    f.a = b1 / s11;
  }
  return f;
}

/// A progress line over the whole sweep, drawn on stderr when it is a terminal.
class SweepProgress {
 public:
  /// \param total runs planned (the reference render included); \param budget 0: none.
  SweepProgress(int total, double budget, bool enabled, Clock::time_point start)
      : total_(total), budget_(budget), enabled_(enabled), start_(start) {}
  /// \brief Counts a run as done (or skipped).
  void advance() { ++done_; }
  /// \brief Names what runs now.
  void set_label(std::string label) { label_ = std::move(label); }
  /// \brief Redraws, at most 10 times a second.
  void draw(bool force = false) {
    if (!enabled_) return;
    const auto now = Clock::now();
    if (!force && std::chrono::duration<double>(now - last_).count() < 0.1) return;
    last_ = now;
    const int width = 24, filled = total_ ? int(double(done_) / total_ * width + 0.5) : width;
    char times[64];
    if (budget_ > 0)
      std::snprintf(times, sizeof times, "%.0f / %.0f s budget", since(start_), budget_);
    else
      std::snprintf(times, sizeof times, "%.0f s", since(start_));
    std::fprintf(stderr, "\r[%.*s%*s] %d/%d runs  %s  %.40s\033[K", filled,
                 "########################", width - filled, "", done_, total_, times,
                 label_.c_str());
    std::fflush(stderr);
    drawn_ = true;
  }
  /// \brief Ends the line if anything was drawn.
  void finish() {
    if (drawn_) std::fprintf(stderr, "\n");
    drawn_ = false;
  }
  /// \brief Erases the line, so that a message can take it; the next draw redraws it.
  void clear() {
    if (drawn_) std::fprintf(stderr, "\r\033[K");
    drawn_ = false;
  }

 private:
  int total_, done_ = 0;
  double budget_;
  bool enabled_, drawn_ = false;
  Clock::time_point start_, last_{};
  std::string label_;
};

/// Powers of 2 from 1 up to \p spp_max, and spp_max itself if it is not one.
std::vector<int> spp_values(int spp_max) {
  std::vector<int> v;
  for (int s = 1; s <= spp_max; s *= 2) v.push_back(s);
  if (v.back() != spp_max) v.push_back(spp_max);
  return v;
}

/// JSON number or null.
json num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

/// CSV field: quoted if it holds a comma, quote or newline.
std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

/// CSV number ("" for NaN).
std::string csv_num(double v) { return std::isfinite(v) ? format_number(v) : ""; }

/// The study itself, once the command line is checked.
class Study {
 public:
  explicit Study(Options opt) : opt_(std::move(opt)), start_(Clock::now()) {}
  /// Runs everything; returns the exit code.
  int run();

 private:
  /// True if --budget was given.
  bool budgeted() const { return opt_.budget > 0; }
  /// Seconds left before the sweep must stop (infinite without a budget).
  double left() const { return budgeted() ? limit_ - since(start_) : INFINITY; }
  /// Deadline for a child, if there is a budget.
  std::optional<Clock::time_point> deadline() const {
    if (!budgeted()) return std::nullopt;
    return start_ + std::chrono::duration_cast<Clock::duration>(
                        std::chrono::duration<double>(limit_));
  }
  /// Prints a message on stderr (not with --quiet), above the progress line.
  void note(const std::string& s) const {
    if (opt_.quiet) return;
    if (progress_) progress_->clear();
    std::cerr << "basalt study: " << s << "\n";
  }
  /// The --help text of the child binary (which knobs it has).
  std::string probe_help();
  /// Builds the settings, the points and the ordered runs.
  void plan();
  /// Runs one child render and reads its statistics.
  void execute(Run& run);
  /// Renders (or finds in the cache) the reference; returns an exit code.
  int make_reference();
  /// Scores every finished run against the reference and fits the default curves.
  void score();
  /// The --compare block (null without --compare).
  json compare_block();
  /// Everything study.json holds.
  json to_json() const;
  /// study.csv: one row per point.
  std::string to_csv() const;
  /// Runs tools/study_report.py; returns an exit code.
  int report();

  Options opt_;
  Clock::time_point start_;
  double limit_ = INFINITY;  // seconds from start_ by which the last child must end
  fs::path dir_, exe_;
  int width_ = 0, height_ = 0;
  std::vector<Knob> table_;
  std::map<std::string, bool> available_, selected_;
  std::vector<Setting> settings_;
  std::vector<Point> points_;
  std::vector<Run> runs_;
  TimeModel model_;
  std::unique_ptr<SweepProgress> progress_;
  std::map<std::string, ErrorFit> fits_;
  std::map<std::string, std::pair<double, double>> startup_rate_;  // default curve, per device
  Image reference_;
  json ref_info_, compare_;
  json default_quality_ = json::object();
};

std::string Study::probe_help() {
  const fs::path out = dir_ / ".help.txt", err = dir_ / ".help.err";
  ChildResult r =
      run_child({exe_.string(), "--help"}, out.string(), err.string(), std::nullopt, {});
  std::string help = read_text(out);
  std::error_code ec;
  fs::remove(out, ec);
  fs::remove(err, ec);
  if (r.exit_code != 0)
    throw std::runtime_error("'" + exe_.string() + " --help' failed: " + r.error);
  return help;
}

void Study::plan() {
  // Settings: the default, then each selected, available knob at each non-default value.
  settings_.push_back({"default", "", "image", {}});
  for (const Knob& k : table_) {
    if (k.name == "spp" || !selected_[k.name] || !available_[k.name]) continue;
    for (const auto& v : k.values)
      if (v != k.default_value) settings_.push_back({k.name, v, k.kind, {k.option, v}});
  }
  // Points and runs, cheap and informative first: seed 1 over spp ascending, round-robin over
  // the settings (the default first) and devices, then the same for each further seed. So a
  // budget leaves every knob a curve before it buys error bars, the default's 1-spp runs come
  // first (they calibrate the time model), and each setting runs right after the default at
  // the same spp: on a shared machine, whose load drifts, their times are comparable.
  const std::vector<int> spps = spp_values(opt_.spp_max);
  std::vector<std::tuple<int, int, int>> order;  // (spp, seed, setting); devices innermost
  for (int seed = 1; seed <= opt_.seeds; ++seed)
    for (int spp : spps)
      for (int s = 0; s < int(settings_.size()); ++s) order.push_back({spp, seed, s});
  std::map<std::tuple<int, std::string, int>, int> point_of;
  for (auto [spp, seed, s] : order)
    for (const auto& dev : opt_.devices) {
      auto [it, fresh] = point_of.try_emplace({s, dev, spp}, int(points_.size()));
      if (fresh) points_.push_back({s, spp, dev, {}});
      Run r;
      r.point = it->second;
      r.seed = seed;
      const Setting& st = settings_[s];
      r.id = file_safe((st.knob == "default" ? std::string("default") : st.knob + "-" + st.value) +
                       "-" + dev + "-" + std::to_string(spp) + "spp-s" + std::to_string(seed));
      r.image = (dir_ / "points" / (r.id + ".exr")).string();
      r.stats = (dir_ / "points" / (r.id + ".json")).string();
      points_[it->second].runs.push_back(int(runs_.size()));
      runs_.push_back(std::move(r));
    }
}

void Study::execute(Run& run) {
  const Point& p = points_[run.point];
  const Setting& st = settings_[p.setting];
  std::vector<std::string> args = {exe_.string(), opt_.scene, "--device", p.device, "--spp",
                                   std::to_string(p.spp), "--seed", std::to_string(run.seed),
                                   "-q", "-o", run.image, "--stats", run.stats};
  args.insert(args.end(), st.args.begin(), st.args.end());
  std::error_code ec;
  fs::remove(run.image, ec);
  fs::remove(run.stats, ec);
  const fs::path log = dir_ / "points" / (run.id + ".log");
  if (progress_)
    progress_->set_label(st.key() + " " + p.device + " " + std::to_string(p.spp) + " spp seed " +
                         std::to_string(run.seed));
  ChildResult r = run_child(args, "/dev/null", log.string(), deadline(), [&] {
    if (progress_) progress_->draw();
  });
  run.seconds_process = r.seconds;
  if (r.stopped) {  // cut off by the budget: counted as skipped, not as a failure
    run.state = Run::State::Skipped;
    run.error = r.error;
    return;
  }
  if (r.exit_code != 0 || !fs::exists(run.image) || !fs::exists(run.stats)) {
    run.state = Run::State::Failed;
    run.error = r.exit_code == 0 ? "no image or statistics written" : r.error;
    return;
  }
  try {
    const json s = json::parse(read_text(run.stats));
    run.seconds_render = s.value("seconds_render", NAN);
    run.seconds_pipeline = s.value("seconds_pipeline", NAN);
    run.device_name = s.value("device", "");
    if (s.contains("quality")) run.quality = s["quality"];
  } catch (const std::exception& e) {
    run.state = Run::State::Failed;
    run.error = std::string("unreadable statistics: ") + e.what();
    return;
  }
  run.state = Run::State::Done;
  fs::remove(log, ec);
  model_.add(p.device, st.key(), p.spp, run.seconds_process,
             std::isfinite(run.seconds_render) ? run.seconds_render : run.seconds_process);
  if (st.knob == "default" && default_quality_.empty() && run.quality.is_object())
    default_quality_ = run.quality;
}

int Study::make_reference() {
  if (!opt_.reference.empty()) {
    ref_info_ = {{"path", fs::absolute(opt_.reference).string()}, {"given", true}};
    return 0;
  }
  // Device: the one asked for, else the one predicted fastest from the calibration runs.
  int spp = opt_.reference_spp > 0 ? opt_.reference_spp : 16 * opt_.spp_max;
  const std::string scene_bytes = read_text(opt_.scene);
  auto cached = [&](int n) {
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx",
                  (unsigned long long)fnv1a(std::to_string(n) + " spp", fnv1a(scene_bytes)));
    return dir_ / ("reference-" + std::string(hex) + ".exr");
  };
  std::string device = opt_.reference_device;
  double predicted = NAN;
  for (const auto& d : opt_.devices) {
    auto t = model_.predict(d, "default", spp);
    if (opt_.reference_device.empty() && t && !(*t >= predicted)) predicted = *t, device = d;
    if (d == opt_.reference_device && t) predicted = *t;
  }
  if (device.empty()) device = opt_.devices.front();
  bool reduced = false;
  // The reference may use up to half the budget; fewer samples (a power of 2) if it must.
  if (budgeted() && !fs::exists(cached(spp)) && std::isfinite(predicted)) {
    const double at1 = *model_.predict(device, "default", 1),
                 per = *model_.predict(device, "default", 2) - at1;
    const double room = 0.5 * opt_.budget - since(start_);
    while (spp > 1 && predicted > room) {
      spp /= 2;
      predicted = at1 + per * (spp - 1);
      reduced = true;
      if (fs::exists(cached(spp))) break;
    }
    if (progress_) progress_->clear();
    if (reduced)
      std::cerr << "basalt study: warning: the reference is reduced to " << spp
                << " spp to fit half the budget; errors near 1/" << spp
                << " of the signal are the reference's own noise\n";
  }
  const fs::path path = cached(spp);
  ref_info_ = {{"path", fs::absolute(path).string()}, {"given", false}, {"spp", spp},
               {"device", device}, {"seed", kReferenceSeed}, {"reduced_for_budget", reduced},
               {"cached", fs::exists(path)}};
  if (fs::exists(path)) {
    note("reusing the cached reference " + path.string());
    try {
      const json s = json::parse(read_text(fs::path(path).replace_extension(".json")));
      ref_info_["seconds_render"] = num(s.value("seconds_render", NAN));
      ref_info_["device_name"] = s.value("device", "");
    } catch (const std::exception&) {
    }
    if (progress_) progress_->advance();
    return 0;
  }
  note("rendering the reference: " + std::to_string(spp) + " spp on " + device +
       (std::isfinite(predicted) ? " (about " + std::to_string(int(predicted + 0.5)) + " s)" : ""));
  const fs::path stats = fs::path(path).replace_extension(".json"), log = dir_ / "reference.log";
  if (progress_) progress_->set_label("reference, " + std::to_string(spp) + " spp on " + device);
  ChildResult r = run_child({exe_.string(), opt_.scene, "--device", device, "--spp",
                             std::to_string(spp), "--seed", std::to_string(kReferenceSeed), "-q",
                             "-o", path.string(), "--stats", stats.string()},
                            "/dev/null", log.string(), deadline(), [&] {
                              if (progress_) progress_->draw();
                            });
  if (progress_) progress_->advance();
  if (r.exit_code != 0 || !fs::exists(path)) {
    if (progress_) progress_->finish();
    std::cerr << "basalt study: error: the reference render failed: " << r.error << "\n";
    return kExitInput;
  }
  std::error_code ec;
  fs::remove(log, ec);
  ref_info_["seconds_process"] = r.seconds;
  try {
    const json s = json::parse(read_text(stats));
    ref_info_["seconds_render"] = num(s.value("seconds_render", NAN));
    ref_info_["device_name"] = s.value("device", "");
  } catch (const std::exception&) {
  }
  return 0;
}

void Study::score() {
  // Default runs by (device, spp, seed): every setting's image is compared with the default's
  // (a time knob must leave it unchanged; an image knob the scene does not use leaves it too).
  std::map<std::tuple<std::string, int, int>, const Run*> defaults;
  for (const Run& r : runs_)
    if (r.state == Run::State::Done && settings_[points_[r.point].setting].knob == "default")
      defaults[{points_[r.point].device, points_[r.point].spp, r.seed}] = &r;
  std::map<std::string, Image> default_images;  // by path, read once
  for (Run& r : runs_) {
    if (r.state != Run::State::Done) continue;
    const Point& p = points_[r.point];
    try {
      const Image img = read_exr(r.image);
      r.rel_mse = rel_mse(img, reference_);
      r.ssim_error = 1.0 - ssim(img, reference_);
      auto d = defaults.find({p.device, p.spp, r.seed});
      if (settings_[p.setting].knob != "default" && d != defaults.end()) {
        auto [it, fresh] = default_images.try_emplace(d->second->image);
        if (fresh) it->second = read_exr(d->second->image);
        r.max_abs_diff = max_abs_diff(img, it->second);
      }
    } catch (const std::exception& e) {
      r.state = Run::State::Failed;
      r.error = std::string("cannot score the image: ") + e.what();
    }
  }
  // The default curve per device: relMSE = a / spp + c; process time = startup + rate * spp.
  for (const auto& dev : opt_.devices) {
    std::vector<std::pair<double, double>> pts;
    for (const Point& p : points_) {
      if (p.device != dev || settings_[p.setting].knob != "default") continue;
      std::vector<double> e;
      for (int i : p.runs)
        if (runs_[i].state == Run::State::Done) e.push_back(runs_[i].rel_mse);
      if (!e.empty()) pts.push_back({double(p.spp), mean_stderr(e).first});
    }
    fits_[dev] = fit_error(pts);
    if (auto sr = model_.startup_rate(dev, "default")) startup_rate_[dev] = *sr;
  }
}

json Study::compare_block() {
  if (opt_.compare.empty()) return nullptr;
  const Image other = read_exr(opt_.compare);
  const double err = rel_mse(other, reference_);
  const std::string name = opt_.compare_name.empty() ? fs::path(opt_.compare).stem().string()
                                                     : opt_.compare_name;
  json c = {{"image", fs::absolute(opt_.compare).string()}, {"name", name},
            {"seconds", opt_.compare_time}, {"rel_mse", num(err)},
            {"ssim_error", num(1.0 - ssim(other, reference_))}, {"devices", json::array()}};
  for (const auto& dev : opt_.devices) {
    // The default curve on this device: mean process time and relMSE per spp.
    std::vector<double> spp, t, e;
    for (const Point& p : points_) {
      if (p.device != dev || settings_[p.setting].knob != "default") continue;
      std::vector<double> ev, tv;
      for (int i : p.runs)
        if (runs_[i].state == Run::State::Done)
          ev.push_back(runs_[i].rel_mse), tv.push_back(runs_[i].seconds_process);
      if (ev.empty()) continue;
      spp.push_back(p.spp), t.push_back(mean_stderr(tv).first), e.push_back(mean_stderr(ev).first);
    }
    json d = {{"device", dev}};
    double seconds = NAN;
    std::string method;
    if (e.empty()) {
      method = "no measurements";
    } else if (err >= e.front()) {
      seconds = t.front();
      method = "at most";  // basalt's fewest samples already do better
    } else {
      // First crossing of the measured curve, interpolated log time against log error.
      for (std::size_t i = 0; i + 1 < e.size() && method.empty(); ++i)
        if (err <= e[i] && err >= e[i + 1] && e[i] > 0 && e[i + 1] > 0 && e[i] != e[i + 1]) {
          const double f = std::log(err / e[i]) / std::log(e[i + 1] / e[i]);
          seconds = std::exp(std::log(t[i]) + f * (std::log(t[i + 1]) - std::log(t[i])));
          method = "interpolated";
        }
      if (method.empty()) {
        // Beyond the measurements: samples from relMSE = a / spp + c, time from the line fit.
        const ErrorFit& f = fits_[dev];
        auto sr = startup_rate_.find(dev);
        if (std::isfinite(f.a) && err > f.c && sr != startup_rate_.end() && sr->second.second > 0) {
          const double need = f.a / (err - f.c);
          seconds = sr->second.first + sr->second.second * need;
          d["spp_needed"] = need;
          method = "extrapolated";
        } else {
          method = "not reached";  // below the fitted floor c, or no time fit
        }
      }
    }
    d["seconds"] = num(seconds);
    d["method"] = method;
    d["ratio"] = num(seconds / opt_.compare_time);
    char buf[512];
    if (std::isfinite(seconds))
      std::snprintf(buf, sizeof buf,
                    "basalt on %s reaches the error of %s (relMSE %.3g) in %s%.3g s against its "
                    "%.3g s: "
                    "%.3gx%s.",
                    dev.c_str(), name.c_str(), err, method == "at most" ? "at most " : "", seconds,
                    opt_.compare_time, seconds / opt_.compare_time,
                    method == "extrapolated" ? " (extrapolated beyond the measured spp)" : "");
    else
      std::snprintf(buf, sizeof buf,
                    "basalt on %s does not reach the error of %s (relMSE %.3g) within the study "
                    "(%s).",
                    dev.c_str(), name.c_str(), err, method.c_str());
    d["sentence"] = buf;
    c["devices"].push_back(d);
  }
  return c;
}

json Study::to_json() const {
  json j;
  j["version"] = 1;
  j["scene"] = fs::absolute(opt_.scene).string();
  j["scene_name"] = fs::path(opt_.scene).stem().string();
  j["width"] = width_, j["height"] = height_;
  j["machine"] = {{"cpu", cpu_model()},
                  {"cores", std::thread::hardware_concurrency()},
                  {"basalt_commit", BASALT_GIT_COMMIT}};
  j["options"] = {{"spp_max", opt_.spp_max}, {"seeds", opt_.seeds}, {"devices", opt_.devices},
                  {"budget_seconds", budgeted() ? json(opt_.budget) : json(nullptr)},
                  {"spp", spp_values(opt_.spp_max)}};
  j["reference"] = ref_info_;
  j["default_quality"] = default_quality_;
  j["knobs"] = json::array();
  for (const Knob& k : table_) {
    json v = k.name == "spp" ? json(spp_values(opt_.spp_max)) : json(k.values);
    j["knobs"].push_back({{"name", k.name}, {"option", k.option}, {"kind", k.kind},
                          {"default", k.default_value}, {"values", v},
                          {"available", available_.at(k.name)},
                          {"selected", selected_.at(k.name)}});
  }
  j["points"] = json::array();
  int skipped = 0, failed = 0, done = 0;
  for (const Point& p : points_) {
    const Setting& st = settings_[p.setting];
    std::vector<double> e, s, tr, tp, tpipe, diff;
    int ok = 0, fail = 0, skip = 0;
    std::string failure, device_name;
    for (int i : p.runs) {
      const Run& r = runs_[i];
      if (r.state == Run::State::Done) {
        ++ok;
        e.push_back(r.rel_mse), s.push_back(r.ssim_error), tr.push_back(r.seconds_render);
        tp.push_back(r.seconds_process), tpipe.push_back(r.seconds_pipeline);
        if (std::isfinite(r.max_abs_diff)) diff.push_back(r.max_abs_diff);
        device_name = r.device_name;
      } else if (r.state == Run::State::Failed) {
        ++fail;
        if (failure.empty()) failure = r.error;
      } else {
        ++skip;
      }
    }
    done += ok, failed += fail, skipped += skip;
    auto [em, ese] = mean_stderr(e);
    auto [sm, sse] = mean_stderr(s);
    json q = {{"knob", st.knob}, {"value", st.value}, {"kind", st.kind}, {"device", p.device},
              {"device_name", device_name}, {"spp", p.spp}, {"seeds", ok},
              {"seeds_planned", int(p.runs.size())}, {"seeds_failed", fail},
              {"rel_mse_mean", num(em)}, {"rel_mse_stderr", num(ese)},
              {"ssim_error_mean", num(sm)}, {"ssim_error_stderr", num(sse)},
              {"seconds_render", num(mean_stderr(tr).first)},
              {"seconds_render_sd", num(mean_stderr(tr).second * std::sqrt(double(tr.size())))},
              {"seconds_process", num(mean_stderr(tp).first)},
              {"seconds_pipeline", num(mean_stderr(tpipe).first)},
              {"max_abs_diff_vs_default",
               diff.empty() ? json(nullptr) : json(*std::max_element(diff.begin(), diff.end()))},
              {"failed", ok == 0 && fail > 0}, {"skipped", ok == 0 && fail == 0},
              {"failure", failure}};
    j["points"].push_back(q);
  }
  j["runs"] = {{"done", done}, {"failed", failed}, {"skipped", skipped}};
  j["fits"] = json::object();
  for (const auto& [dev, f] : fits_) {
    json fj = {{"a", num(f.a)}, {"c", num(f.c)}, {"points", f.points}};
    auto sr = startup_rate_.find(dev);
    if (sr != startup_rate_.end())
      fj["startup_seconds"] = num(sr->second.first), fj["seconds_per_spp"] = num(sr->second.second);
    j["fits"][dev] = fj;
  }
  j["compare"] = compare_;
  j["elapsed_seconds"] = since(start_);
  return j;
}

std::string Study::to_csv() const {
  std::ostringstream o;
  o << "knob,value,kind,device,spp,seeds,seeds_planned,rel_mse_mean,rel_mse_stderr,"
       "ssim_error_mean,ssim_error_stderr,seconds_render,seconds_render_sd,seconds_process,"
       "seconds_pipeline,"
       "max_abs_diff_vs_default,failed,skipped,failure\n";
  const json j = to_json();
  for (const json& p : j["points"]) {
    auto n = [&](const char* k) {
      return p[k].is_null() ? std::string() : csv_num(p[k].get<double>());
    };
    o << csv_field(p["knob"]) << "," << csv_field(p["value"]) << "," << p["kind"].get<std::string>()
      << "," << csv_field(p["device"]) << "," << p["spp"] << "," << p["seeds"] << ","
      << p["seeds_planned"] << "," << n("rel_mse_mean") << "," << n("rel_mse_stderr") << ","
      << n("ssim_error_mean") << "," << n("ssim_error_stderr") << "," << n("seconds_render") << ","
      << n("seconds_render_sd") << ","
      << n("seconds_process") << "," << n("seconds_pipeline") << ","
      << n("max_abs_diff_vs_default") << "," << (p["failed"].get<bool>() ? 1 : 0) << ","
      << (p["skipped"].get<bool>() ? 1 : 0) << "," << csv_field(p["failure"]) << "\n";
  }
  return o.str();
}

int Study::report() {
  const std::string script =
      opt_.report_script.empty() ? std::string(BASALT_SOURCE_DIR) + "/tools/study_report.py"
                                 : opt_.report_script;
  if (!fs::exists(script)) {
    std::cerr << "basalt study: error: report script " << script
              << " not found (--report-script)\n";
    return kExitInput;
  }
  if (::access(opt_.python.c_str(), X_OK) != 0) {
    std::cerr << "basalt study: warning: " << opt_.python
              << " not found: no charts or report.md (install python3 and python3-matplotlib); "
                 "the table is in "
              << (dir_ / "study.json").string() << "\n";
    return 0;
  }
  const fs::path log = dir_ / "report.log";
  // Under a budget the script gets the seconds left and leaves out the charts that would not
  // fit (the spp chart first, then relMSE, then 1 - SSIM).
  std::vector<std::string> args = {opt_.python, script, (dir_ / "study.json").string()};
  if (budgeted())
    args.insert(args.end(),
                {"--seconds", std::to_string(std::max(1.0, opt_.budget - since(start_) - 1.0))});
  ChildResult r = run_child(args,
                            (dir_ / "report.out").string(), log.string(), std::nullopt, {});
  std::error_code ec;
  fs::remove(dir_ / "report.out", ec);
  if (r.exit_code == kReportNoMatplotlib) {
    fs::remove(log, ec);
    std::cerr << "basalt study: warning: python matplotlib is missing (install "
                 "python3-matplotlib): report.md has no charts; the table is in "
              << (dir_ / "study.json").string() << "\n";
    return 0;
  }
  if (r.exit_code != 0) {
    std::cerr << "basalt study: error: the report script failed: " << r.error << "\n";
    return kExitInput;
  }
  fs::remove(log, ec);
  return 0;
}

int Study::run() {
  // The scene's resolution, and its parse errors before any child runs.
  const Scene scene = load_scene(opt_.scene);
  width_ = scene.film.xres, height_ = scene.film.yres;
  if (!opt_.reference.empty()) {
    reference_ = read_exr(opt_.reference);
    if (reference_.width != width_ || reference_.height != height_) {
      std::cerr << "basalt study: error: reference " << opt_.reference << " is "
                << reference_.width << "x" << reference_.height << ", the scene renders "
                << width_ << "x" << height_ << "\n";
      return kExitInput;
    }
    ref_info_ = {{"path", fs::absolute(opt_.reference).string()}, {"given", true}};
  }
  if (!opt_.compare.empty()) {
    const Image other = read_exr(opt_.compare);
    if (other.width != width_ || other.height != height_) {
      std::cerr << "basalt study: error: --compare image " << opt_.compare << " is "
                << other.width << "x" << other.height << ", the scene renders " << width_ << "x"
                << height_ << "\n";
      return kExitInput;
    }
  }
  dir_ = opt_.out.empty() ? fs::path("study-" + fs::path(opt_.scene).stem().string())
                          : fs::path(opt_.out);
  fs::create_directories(dir_ / "points");
  exe_ = self_exe();
  // Budget: the report gets the last fifth (at most 15 s: matplotlib draws 5 charts in 3-8 s
  // on 2 busy cores), or more on a machine so loaded that importing matplotlib alone takes a
  // quarter of that (the report costs about 4 imports: measured here, now, under the load the
  // sweep will see); every child must end before that, and the report gets at most half.
  if (budgeted()) {
    double reserve = std::min(15.0, 0.2 * opt_.budget);
    const auto t0 = Clock::now();
    const ChildResult r = run_child(
        {opt_.python, "-c", "import matplotlib; matplotlib.use('Agg'); import matplotlib.pyplot"},
        "/dev/null", "/dev/null",
        t0 + std::chrono::duration_cast<Clock::duration>(
                 std::chrono::duration<double>(0.25 * opt_.budget)),
        {});
    if (r.exit_code == 0)
      reserve = std::min(0.5 * opt_.budget, std::max(reserve, 4.0 * since(t0) + 2.0));
    limit_ = opt_.budget - reserve;
  }

  const std::string help = probe_help();
  table_ = knobs();
  for (const Knob& k : table_) {
    available_[k.name] = help_has_option(help, k.option);
    selected_[k.name] = opt_.knobs.empty() || k.name == "spp" ||
                        std::find(opt_.knobs.begin(), opt_.knobs.end(), k.name) != opt_.knobs.end();
  }
  std::string missing;
  for (const Knob& k : table_)
    if (!available_[k.name]) missing += (missing.empty() ? "" : ", ") + k.name;
  if (!missing.empty())
    note("not available in this build (no such option in basalt --help): " + missing);
  plan();
  const bool need_reference = opt_.reference.empty();
  progress_ = std::make_unique<SweepProgress>(int(runs_.size()) + (need_reference ? 1 : 0),
                                              opt_.budget, !opt_.quiet && ::isatty(2), start_);
  note(std::to_string(runs_.size()) + " runs planned (" + std::to_string(settings_.size()) +
       " settings, " + std::to_string(spp_values(opt_.spp_max).size()) + " spp values, " +
       std::to_string(opt_.seeds) + " seeds, " + std::to_string(opt_.devices.size()) +
       " devices)" + (budgeted() ? ", budget " + std::to_string(int(opt_.budget)) + " s" : ""));

  // The calibration runs (the default at 1 spp on every device) come first; then the
  // reference, sized from them; then the rest of the sweep.
  const std::size_t calibration = opt_.devices.size();
  for (std::size_t i = 0; i < runs_.size(); ++i) {
    if (i == calibration && need_reference) {
      if (int rc = make_reference()) return rc;
    }
    Run& run = runs_[i];
    const Point& p = points_[run.point];
    auto predicted = model_.predict(p.device, settings_[p.setting].key(), p.spp);
    if (budgeted() && ((predicted && *predicted > left()) || left() <= 0)) {
      run.state = Run::State::Skipped;
    } else {
      execute(run);
    }
    progress_->advance();
    progress_->draw(true);
  }
  if (need_reference && runs_.size() <= calibration) {
    if (int rc = make_reference()) return rc;
  }
  progress_->finish();
  if (need_reference) reference_ = read_exr(ref_info_["path"].get<std::string>());
  score();
  compare_ = compare_block();
  if (!opt_.keep_images)  // one image per point is enough to look at (and 256x256 is 0.7 MB)
    for (const Run& r : runs_)
      if (r.seed > 1) {
        std::error_code ec;
        fs::remove(r.image, ec);
      }

  const json j = to_json();
  // A child's stderr may hold bytes that are not UTF-8: replace them rather than throw.
  write_file_atomic((dir_ / "study.json").string(),
                    j.dump(1, ' ', false, json::error_handler_t::replace) + "\n");
  write_file_atomic((dir_ / "study.csv").string(), to_csv());
  note(std::to_string(j["runs"]["done"].get<int>()) + " runs done, " +
       std::to_string(j["runs"]["skipped"].get<int>()) + " skipped for the budget, " +
       std::to_string(j["runs"]["failed"].get<int>()) + " failed; " +
       (dir_ / "study.json").string());
  for (const json& p : j["points"])
    if (p["failed"].get<bool>() && !opt_.quiet)
      std::cerr << "basalt study: " << p["knob"].get<std::string>() << " "
                << p["value"].get<std::string>() << " on " << p["device"].get<std::string>()
                << " at " << p["spp"] << " spp failed: " << p["failure"].get<std::string>() << "\n";
  if (compare_.is_object())
    for (const json& d : compare_["devices"]) std::cout << d["sentence"].get<std::string>() << "\n";
  const int rc = report();
  if (rc == 0 && fs::exists(dir_ / "report.md")) note("report: " + (dir_ / "report.md").string());
  // Without a single default image there is nothing to compare against: not a usable study.
  bool any_default = false;
  for (const Run& r : runs_)
    any_default |=
        r.state == Run::State::Done && settings_[points_[r.point].setting].knob == "default";
  if (!any_default) {
    std::cerr << "basalt study: error: no default run succeeded (see " << (dir_ / "points").string()
              << "/*.log)\n";
    return kExitInput;
  }
  return rc;
}

}  // namespace

int study_main(int argc, char** argv) {
  CLI::App app{"basalt study: sweep samples per pixel and the quality knobs, each run a child "
               "basalt, and measure error against a reference and time (charts and report.md "
               "in --out)",
               "basalt study"};
  Options opt;
  std::string knob_names;
  for (const Knob& k : knobs()) knob_names += (knob_names.empty() ? "" : ", ") + k.name;
  // Missing files are bad input (exit 1, as for a render), not a bad command line.
  app.add_option("scene", opt.scene, "pbrt-v4 scene file")->required();
  app.add_option("--knobs", opt.knobs,
                 "comma-separated knobs to sweep (default: all): " + knob_names)
      ->delimiter(',');
  app.add_option("--budget", opt.budget,
                 "seconds for the whole study, the reference render and the report included; "
                 "points predicted to overrun are skipped (default: unlimited)")
      ->check(CLI::PositiveNumber);
  app.add_option("--reference", opt.reference,
                 "reference EXR at the scene's resolution (default: rendered once with the "
                 "default knobs and cached in --out)");
  cli::ranged(app, "--reference-spp", opt.reference_spp,
              "samples of the rendered reference (default: 16 x --spp-max)", 1, 1 << 24);
  app.add_option("--reference-device", opt.reference_device,
                 "device of the rendered reference, one of --devices (default: the one "
                 "predicted fastest from the first runs)");
  cli::ranged(app, "--spp-max", opt.spp_max,
              "largest samples per pixel; the sweep runs the powers of 2 up to it (default 64)", 1,
              1 << 20);
  cli::ranged(app, "--seeds", opt.seeds, "seeds per point, 1..K (default 3)", 1, 1000);
  app.add_option("--devices,--device", opt.devices,
                 "comma-separated devices to time (default lavapipe,cpu)")
      ->delimiter(',');
  app.add_option("--out", opt.out, "output directory (default study-<scene name>)");
  auto* cmp = app.add_option("--compare", opt.compare,
                             "another renderer's EXR of the scene: the time basalt needs for its "
                             "error");
  auto* cmp_time = app.add_option("--compare-time", opt.compare_time,
                                  "seconds the --compare image took")
                       ->check(CLI::PositiveNumber);
  cmp->needs(cmp_time);
  cmp_time->needs(cmp);
  app.add_option("--compare-name", opt.compare_name, "name of the other renderer (default: the "
                 "image's file name)")
      ->needs(cmp);
  app.add_option("--report-script", opt.report_script,
                 "the report script (default " BASALT_SOURCE_DIR "/tools/study_report.py)");
  app.add_option("--python", opt.python, "Python with matplotlib for the report (default "
                 "/usr/bin/python3)");
  app.add_flag("--keep-images", opt.keep_images,
               "keep every run's EXR in --out/points (default: seed 1's only)");
  app.add_flag("-q,--quiet", opt.quiet, "no progress line or messages");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : kExitUsage;
  }
  for (const auto& name : opt.knobs) {
    const auto& t = knobs();
    if (std::none_of(t.begin(), t.end(), [&](const Knob& k) { return k.name == name; })) {
      std::cerr << "basalt study: error: unknown knob '" << name << "' (knobs: " << knob_names
                << ")\n";
      return kExitUsage;
    }
  }
  if (opt.devices.empty() ||
      std::any_of(opt.devices.begin(), opt.devices.end(), [](auto& d) { return d.empty(); })) {
    std::cerr << "basalt study: error: --devices needs at least one device name\n";
    return kExitUsage;
  }
  if (!opt.reference_device.empty() && std::find(opt.devices.begin(), opt.devices.end(),
                                                 opt.reference_device) == opt.devices.end()) {
    std::cerr << "basalt study: error: --reference-device must be one of --devices\n";
    return kExitUsage;
  }
  try {
    return Study(opt).run();
  } catch (const SceneError& e) {
    std::cerr << e.what() << "\n";
  } catch (const std::exception& e) {
    std::cerr << "basalt study: error: " << e.what() << "\n";
  }
  return kExitInput;
}

}  // namespace basalt::study
