// SourceLoc and SceneError: locations and messages for scene input problems.
#include "scene/scene.h"

namespace basalt {

std::string SourceLoc::str() const {
  if (line <= 0) return file;
  return file + ":" + std::to_string(line) + ":" + std::to_string(column);
}

SceneError::SceneError(const SourceLoc& l, const std::string& msg)
    : std::runtime_error(l.str() + ": error: " + msg), loc(l), message(msg) {}

}  // namespace basalt
