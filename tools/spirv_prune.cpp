// Build step of cmake/Shaders.cmake for a shader variant that rules feature bits out for good
// (BASALT_FEATURES_KEEP, BASALT_FEATURES2_KEEP in bindings.glsl): glslang leaves the code
// under a test of those bits behind a constant-false branch; this removes it (dead branches,
// then the constants that glslang's short-circuit phis left, then dead functions and code) and
// writes the module as a C header like glslang's --vn, so that the specialisation at scene
// time (host/vk/specialise.cpp) starts from a smaller module. No inlining and no other
// transformation: the scene-time specialisation of a pruned module gives the code it gave the
// full one (docs/performance.md, "Variants pruned at build time").
//
//   basalt_spirv_prune IN.spv OUT.spv.h NAME
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

#include <spirv-tools/optimizer.hpp>

int main(int argc, char** argv) {
  if (argc != 4) {
    std::cerr << "usage: basalt_spirv_prune IN.spv OUT.spv.h NAME\n";
    return 2;
  }
  std::ifstream in(argv[1], std::ios::binary);
  const std::vector<char> bytes{std::istreambuf_iterator<char>(in), {}};
  if (!in || bytes.empty() || bytes.size() % 4 != 0) {
    std::cerr << "basalt_spirv_prune: cannot read SPIR-V from " << argv[1] << "\n";
    return 1;
  }
  std::vector<std::uint32_t> words(bytes.size() / 4);
  std::copy(bytes.begin(), bytes.end(), reinterpret_cast<char*>(words.data()));

  spvtools::Optimizer opt(SPV_ENV_VULKAN_1_1);
  opt.SetMessageConsumer([](spv_message_level_t level, const char*, const spv_position_t&,
                            const char* message) {
    if (level <= SPV_MSG_ERROR) std::cerr << "basalt_spirv_prune: " << message << "\n";
  });
  opt.RegisterPass(spvtools::CreateDeadBranchElimPass())
      .RegisterPass(spvtools::CreateCCPPass())
      .RegisterPass(spvtools::CreateDeadBranchElimPass())
      .RegisterPass(spvtools::CreateEliminateDeadFunctionsPass())
      .RegisterPass(spvtools::CreateAggressiveDCEPass());
  std::vector<std::uint32_t> out;
  if (!opt.Run(words.data(), words.size(), &out)) return 1;  // validates the result too

  // Written to a temporary name and renamed: the build never sees half a header.
  const std::string path = argv[2], tmp = path + ".tmp";
  {
    std::ofstream o(tmp);
    o << "// " << argv[1] << " pruned by basalt_spirv_prune (" << words.size() * 4 << " -> "
      << out.size() * 4 << " bytes)\n#pragma once\nconst uint32_t " << argv[3] << "[] = {";
    char word[16];
    for (std::size_t i = 0; i < out.size(); ++i) {
      std::snprintf(word, sizeof(word), "0x%08x,", out[i]);
      o << (i % 8 == 0 ? "\n\t" : "") << word;
    }
    o << "\n};\n";
    if (!o) {
      std::cerr << "basalt_spirv_prune: cannot write " << tmp << "\n";
      return 1;
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::cerr << "basalt_spirv_prune: cannot rename " << tmp << " to " << path << "\n";
    return 1;
  }
  return 0;
}
