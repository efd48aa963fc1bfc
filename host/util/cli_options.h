// Option helpers shared by basalt's command lines (host/main.cpp, host/study/study.cpp).
#pragma once
#include <CLI/CLI.hpp>

#include <string>

namespace basalt::cli {

/// \brief A numeric option whose value must lie in [\p lo, \p hi] (else a bad command line).
template <typename T>
CLI::Option* ranged(CLI::App& app, const std::string& name, T& var, const std::string& help, T lo,
                    T hi) {
  return app.add_option(name, var, help)->check(CLI::Range(lo, hi));
}

}  // namespace basalt::cli
