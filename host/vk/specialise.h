// Specialisation of a shader's SPIR-V for one scene before the driver sees it: the feature
// words (specialization constants 0 and 1, shaders/include/bindings.glsl) frozen to the
// scene's values and the code they rule out removed (docs/performance.md, issue 12).
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

namespace basalt::vkx {

/// \brief The module \p words (\p bytes long) with its 32-bit specialization constants 0, 1,
/// ... set to \p constants (the feature words, then the table-format constants of
/// shaders/include/bindings.glsl) and frozen, and the branches, functions and code they make
/// dead removed (SPIRV-Tools: fold, dead-branch elimination, dead functions, aggressive DCE,
/// then conditional constant propagation for the short-circuited tests and the same again).
/// The result computes what the driver would with those constants, in less code: lavapipe
/// inlines every call before it folds a constant, so dead code costs it time and memory.
/// \throws std::runtime_error if SPIRV-Tools rejects the module.
std::vector<std::uint32_t> specialise_spirv(const std::uint32_t* words, std::size_t bytes,
                                            const std::vector<std::uint32_t>& constants);

/// \brief specialise_spirv through a per-user disk cache: $BASALT_CACHE_DIR, else
/// $XDG_CACHE_HOME/basalt, else ~/.cache/basalt (as Mesa keeps its shader cache); the file name
/// is a 64-bit hash of the module and the constants, the file holds a hash of its contents, so
/// a changed shader or a damaged file is specialised afresh. BASALT_CACHE_DIR=off (or no
/// writable directory) skips the cache. Past 64 MiB the least recently used entries are
/// removed down to 48 MiB. Sets \p hit to whether the cache answered.
std::vector<std::uint32_t> specialise_spirv_cached(const std::uint32_t* words, std::size_t bytes,
                                                   const std::vector<std::uint32_t>& constants,
                                                   bool& hit);

}  // namespace basalt::vkx
