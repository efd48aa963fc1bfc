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
/// A result over \p inline_above words is then inlined into its entry point, with the loads of
/// stored values forwarded (merge return, exhaustive inlining, dead functions, local
/// single-block and single-store elimination, aggressive DCE), which lavapipe translates in
/// about 60% of the time; a smaller one keeps its functions (inlining costs more there than
/// it saves).
/// \throws std::runtime_error if SPIRV-Tools rejects the module.
/// Size in words above which specialise_spirv inlines its result by default (192 KiB: the
/// Cornell box's megakernel, 143 KiB, stays below, the shade modules of coated and textured
/// scenes, 210-350 KiB, above). The wavefront's stages pass 0: all of them are inlined.
inline constexpr std::size_t kInlineAboveWords = 192u * 1024u / 4u;

std::vector<std::uint32_t> specialise_spirv(const std::uint32_t* words, std::size_t bytes,
                                            const std::vector<std::uint32_t>& constants,
                                            std::size_t inline_above = kInlineAboveWords);

/// Whether specialise_spirv inlines large results (tests turn it off to compare the images;
/// specialise_spirv_cached then bypasses the cache).
inline bool inline_large_modules = true;

/// \brief specialise_spirv through a per-user disk cache: $BASALT_CACHE_DIR, else
/// $XDG_CACHE_HOME/basalt, else ~/.cache/basalt (as Mesa keeps its shader cache); the file name
/// is a 64-bit hash of the module and the constants, the file holds a hash of its contents, so
/// a changed shader or a damaged file is specialised afresh. BASALT_CACHE_DIR=off (or no
/// writable directory) skips the cache. Past 64 MiB the least recently used entries are
/// removed down to 48 MiB. Sets \p hit to whether the cache answered.
std::vector<std::uint32_t> specialise_spirv_cached(const std::uint32_t* words, std::size_t bytes,
                                                   const std::vector<std::uint32_t>& constants,
                                                   bool& hit,
                                                   std::size_t inline_above = kInlineAboveWords);

}  // namespace basalt::vkx
