// `basalt study SCENE.pbrt`: what accuracy costs in time. Sweeps samples per pixel and the
// quality knobs, each point a child run of basalt, measures error against a reference and
// time, and writes study.json, study.csv and (through tools/study_report.py) charts and a report.
#pragma once
#include <string>
#include <vector>

namespace basalt::study {

/// One quality knob the study can sweep: a row of the table in study.cpp.
struct Knob {
  std::string name;                 ///< study name, e.g. "texture-filter"
  std::string option;               ///< basalt's option, e.g. "--texture-filter"
  std::vector<std::string> values;  ///< the settings swept besides the default
  std::string default_value;        ///< what runs when the option is not given
  std::string kind;                 ///< "image" (changes the image) or "time" (must not)
};

/// \brief The knob table, "spp" (the x-axis of every curve) first.
const std::vector<Knob>& knobs();

/// \brief Runs `basalt study` with \p argv[0] = "study"; returns the exit code
///        (0 success, 1 bad input or no usable result, 2 bad command line).
int study_main(int argc, char** argv);

}  // namespace basalt::study
