// Scene specialisation of SPIR-V with SPIRV-Tools' optimizer (see specialise.h).
#include "vk/specialise.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include <spirv-tools/optimizer.hpp>

namespace basalt::vkx {

namespace {

/// Adds the passes that inline a module into its entry point and forward its loads of stored
/// values (see specialise_spirv).
void add_inline_passes(spvtools::Optimizer& opt) {
  opt.RegisterPass(spvtools::CreateMergeReturnPass())
      .RegisterPass(spvtools::CreateInlineExhaustivePass())
      .RegisterPass(spvtools::CreateEliminateDeadFunctionsPass())
      .RegisterPass(spvtools::CreateLocalSingleBlockLoadStoreElimPass())
      .RegisterPass(spvtools::CreateLocalSingleStoreElimPass())
      .RegisterPass(spvtools::CreateAggressiveDCEPass());
}

}  // namespace

std::vector<std::uint32_t> specialise_spirv(const std::uint32_t* words, std::size_t bytes,
                                            const std::vector<std::uint32_t>& constants,
                                            std::size_t inline_above) {
  std::string errors;
  spvtools::Optimizer opt(SPV_ENV_VULKAN_1_1);
  opt.SetMessageConsumer([&errors](spv_message_level_t level, const char*,
                                   const spv_position_t&, const char* message) {
    if (level <= SPV_MSG_ERROR) errors += std::string(message) + "\n";
  });
  std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> values;
  for (std::uint32_t id = 0; id < constants.size(); ++id) values[id] = {constants[id]};
  opt.RegisterPass(spvtools::CreateSetSpecConstantDefaultValuePass(values))
      .RegisterPass(spvtools::CreateFreezeSpecConstantValuePass())
      .RegisterPass(spvtools::CreateFoldSpecConstantOpAndCompositePass())
      .RegisterPass(spvtools::CreateDeadBranchElimPass())
      .RegisterPass(spvtools::CreateEliminateDeadFunctionsPass())
      .RegisterPass(spvtools::CreateAggressiveDCEPass())
      // A condition `has_feature(X) && c` is a phi after the passes above (glslang's
      // short-circuit), constant but not folded, so the code under it stayed: conditional
      // constant propagation folds it, and the dead code goes in a second round.
      .RegisterPass(spvtools::CreateCCPPass())
      .RegisterPass(spvtools::CreateDeadBranchElimPass())
      .RegisterPass(spvtools::CreateEliminateDeadFunctionsPass())
      .RegisterPass(spvtools::CreateAggressiveDCEPass());
  // Inlining whatever the size (the wavefront's stages) runs in the same pass list: parsing
  // and writing the module once saves 13-25% of the specialisation (docs/performance.md).
  const bool inline_all = inline_large_modules && inline_above == 0;
  if (inline_all) add_inline_passes(opt);
  // The module comes from glslang at build time; validating it again would cost more than the
  // passes (0.4 s for the render shader).
  spvtools::OptimizerOptions options;
  options.set_run_validator(false);
  std::vector<std::uint32_t> out;
  if (!opt.Run(words, bytes / sizeof(std::uint32_t), &out, options))
    throw std::runtime_error("SPIR-V specialisation failed: " + errors);
  if (inline_all || !inline_large_modules || out.size() <= inline_above) return out;
  // A large module is inlined here rather than by lavapipe (docs/performance.md, "Inlined
  // before lavapipe"): NIR inlines every call too, then lowers the callees' parameter and
  // local variables at every copy, which made the warm pipeline of a coated or textured
  // scene 0.33-0.5 s. Only loads and stores are forwarded after the inlining (single block,
  // single store): SPIRV-Tools' full SSA rewrite made LLVM's compile up to 2.5x slower.
  spvtools::Optimizer inl(SPV_ENV_VULKAN_1_1);
  inl.SetMessageConsumer([&errors](spv_message_level_t level, const char*,
                                   const spv_position_t&, const char* message) {
    if (level <= SPV_MSG_ERROR) errors += std::string(message) + "\n";
  });
  add_inline_passes(inl);
  std::vector<std::uint32_t> inlined;
  if (!inl.Run(out.data(), out.size(), &inlined, options))
    throw std::runtime_error("SPIR-V inlining failed: " + errors);
  return inlined;
}

namespace {

/// 64-bit FNV-1a of \p n bytes, continuing from \p h.
std::uint64_t fnv1a(const void* data, std::size_t n, std::uint64_t h = 0xcbf29ce484222325ull) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ull;
  return h;
}

/// The cache directory, or empty when caching is off or no home is known.
std::filesystem::path cache_dir() {
  if (const char* d = std::getenv("BASALT_CACHE_DIR"); d && *d)
    return std::string(d) == "off" ? std::filesystem::path() : std::filesystem::path(d);
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x)
    return std::filesystem::path(x) / "basalt";
  if (const char* h = std::getenv("HOME"); h && *h)
    return std::filesystem::path(h) / ".cache" / "basalt";
  return {};
}

// The magic names the passes too: a file written by other passes is specialised afresh
// ("BSPV" before large modules were inlined, "BSP2" before the wavefront's stages were
// specialised and inlined in one pass list).
constexpr std::uint32_t kCacheMagic = 0x33505342u;  // "BSP3"
/// The cache is trimmed to kCacheKeep bytes, least recently used first, when it passes
/// kCacheLimit (each shader change leaves a set of stale entries behind).
constexpr std::uintmax_t kCacheLimit = 64u << 20, kCacheKeep = 48u << 20;

/// Removes the least recently used cache files while the directory holds over kCacheLimit.
void trim_cache(const std::filesystem::path& dir) {
  std::error_code ec;
  std::vector<std::pair<std::filesystem::file_time_type, std::filesystem::path>> files;
  std::uintmax_t total = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    if (!e.is_regular_file(ec) || e.path().filename().string().rfind("spirv-", 0) != 0) continue;
    const std::uintmax_t size = e.file_size(ec);
    if (ec) continue;
    total += size;
    files.push_back({e.last_write_time(ec), e.path()});
  }
  if (total <= kCacheLimit) return;
  std::sort(files.begin(), files.end());
  for (const auto& [time, path] : files) {
    if (total <= kCacheKeep) break;
    const std::uintmax_t size = std::filesystem::file_size(path, ec);
    if (!ec && std::filesystem::remove(path, ec)) total -= size;
  }
}

}  // namespace

std::vector<std::uint32_t> specialise_spirv_cached(const std::uint32_t* words, std::size_t bytes,
                                                   const std::vector<std::uint32_t>& constants,
                                                   bool& hit, std::size_t inline_above) {
  hit = false;
  const std::filesystem::path dir = cache_dir();
  if (dir.empty() || !inline_large_modules)
    return specialise_spirv(words, bytes, constants, inline_above);
  // The key: the module, the constants and the inlining bound.
  const std::uint64_t bound = inline_above;
  const std::uint64_t key =
      fnv1a(&bound, sizeof(bound),
            fnv1a(constants.data(), constants.size() * sizeof(std::uint32_t), fnv1a(words, bytes)));
  char name[40];
  std::snprintf(name, sizeof(name), "spirv-%016llx.bin", static_cast<unsigned long long>(key));
  const std::filesystem::path file = dir / name;
  // File: magic, payload word count, FNV-1a of the payload (two words), payload.
  if (std::ifstream in{file, std::ios::binary}) {
    std::uint32_t head[4] = {};
    if (in.read(reinterpret_cast<char*>(head), sizeof(head)) && head[0] == kCacheMagic &&
        head[1] > 0 && head[1] < (1u << 26)) {
      std::vector<std::uint32_t> out(head[1]);
      const std::uint64_t sum = head[2] | std::uint64_t(head[3]) << 32;
      if (in.read(reinterpret_cast<char*>(out.data()), std::streamsize(out.size() * 4)) &&
          fnv1a(out.data(), out.size() * 4) == sum) {
        hit = true;
        std::error_code ec;  // recently used: kept longest when the cache is trimmed
        std::filesystem::last_write_time(file, std::filesystem::file_time_type::clock::now(), ec);
        return out;
      }
    }
  }
  std::vector<std::uint32_t> out = specialise_spirv(words, bytes, constants, inline_above);
  // Written to a temporary name and renamed, so a reader never sees half a file; a cache
  // that cannot be written is no error (the module is specialised again next time).
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  const std::filesystem::path tmp =
      dir / (std::string(name) + ".tmp" + std::to_string(fnv1a(&out, sizeof(&out))));
  {
    std::ofstream o{tmp, std::ios::binary};
    const std::uint64_t sum = fnv1a(out.data(), out.size() * 4);
    const std::uint32_t head[4] = {kCacheMagic, std::uint32_t(out.size()), std::uint32_t(sum),
                                   std::uint32_t(sum >> 32)};
    o.write(reinterpret_cast<const char*>(head), sizeof(head));
    o.write(reinterpret_cast<const char*>(out.data()), std::streamsize(out.size() * 4));
    if (!o) {
      o.close();
      std::filesystem::remove(tmp, ec);
      return out;
    }
  }
  std::filesystem::rename(tmp, file, ec);
  if (ec) std::filesystem::remove(tmp, ec);
  trim_cache(dir);
  return out;
}

}  // namespace basalt::vkx
