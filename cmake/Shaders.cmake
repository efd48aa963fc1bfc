# basalt_add_shader(NAME SOURCE): compiles SOURCE (GLSL) into the C header
# ${CMAKE_BINARY_DIR}/generated/shaders/NAME.spv.h holding `const uint32_t NAME_spv[]`.
# glslangValidator writes a depfile, so editing an included file rebuilds the shader.
function(basalt_add_shader name source)
  set(out_dir ${CMAKE_BINARY_DIR}/generated/shaders)
  set(out ${out_dir}/${name}.spv.h)
  file(MAKE_DIRECTORY ${out_dir})
  add_custom_command(
    OUTPUT ${out}
    COMMAND ${GLSLANG_VALIDATOR} -V --target-env vulkan1.1 --quiet
            --vn ${name}_spv --depfile ${out}.d -I${CMAKE_SOURCE_DIR}/shaders
            -o ${out} ${CMAKE_SOURCE_DIR}/${source}
    MAIN_DEPENDENCY ${CMAKE_SOURCE_DIR}/${source}
    DEPFILE ${out}.d
    COMMENT "GLSL -> SPIR-V ${source}"
    VERBATIM)
  set(BASALT_SHADER_HEADERS ${BASALT_SHADER_HEADERS} ${out} PARENT_SCOPE)
endfunction()
