# basalt_add_shader(NAME SOURCE [PRUNE] [DEFINES D...]): compiles SOURCE (GLSL) into the C
# header ${CMAKE_BINARY_DIR}/generated/shaders/NAME.spv.h holding `const uint32_t NAME_spv[]`,
# with each D passed to glslangValidator as -DD (so one source can give several variants under
# distinct NAMEs). glslangValidator writes a depfile, so editing an included file rebuilds
# the shader. PRUNE: a variant that rules feature bits out (BASALT_PLAIN in bindings.glsl)
# goes through basalt_spirv_prune (tools/spirv_prune.cpp), which removes the code under its
# constant-false tests before the header is written.
function(basalt_add_shader name source)
  cmake_parse_arguments(PARSE_ARGV 2 arg "PRUNE" "" "DEFINES")
  set(out_dir ${CMAKE_BINARY_DIR}/generated/shaders)
  set(out ${out_dir}/${name}.spv.h)
  set(defines)
  foreach(d IN LISTS arg_DEFINES)
    list(APPEND defines -D${d})
  endforeach()
  file(MAKE_DIRECTORY ${out_dir})
  if(arg_PRUNE)
    set(spv ${out_dir}/${name}.spv)
    add_custom_command(
      OUTPUT ${spv}
      COMMAND ${GLSLANG_VALIDATOR} -V --target-env vulkan1.1 --quiet ${defines}
              --depfile ${spv}.d -I${CMAKE_SOURCE_DIR}/shaders
              -o ${spv} ${CMAKE_SOURCE_DIR}/${source}
      MAIN_DEPENDENCY ${CMAKE_SOURCE_DIR}/${source}
      DEPFILE ${spv}.d
      COMMENT "GLSL -> SPIR-V ${source} as ${name}"
      VERBATIM)
    add_custom_command(
      OUTPUT ${out}
      COMMAND basalt_spirv_prune ${spv} ${out} ${name}_spv
      DEPENDS ${spv} basalt_spirv_prune
      COMMENT "SPIR-V ${name} pruned"
      VERBATIM)
    set(BASALT_SHADER_HEADERS ${BASALT_SHADER_HEADERS} ${out} PARENT_SCOPE)
    return()
  endif()
  add_custom_command(
    OUTPUT ${out}
    COMMAND ${GLSLANG_VALIDATOR} -V --target-env vulkan1.1 --quiet ${defines}
            --vn ${name}_spv --depfile ${out}.d -I${CMAKE_SOURCE_DIR}/shaders
            -o ${out} ${CMAKE_SOURCE_DIR}/${source}
    MAIN_DEPENDENCY ${CMAKE_SOURCE_DIR}/${source}
    DEPFILE ${out}.d
    COMMENT "GLSL -> SPIR-V ${source} as ${name}"
    VERBATIM)
  set(BASALT_SHADER_HEADERS ${BASALT_SHADER_HEADERS} ${out} PARENT_SCOPE)
endfunction()
