# Command-line tests of the basalt binary, run by CTest as `cmake -P`:
# a good render writes EXR, PNG and statistics; every bad-input class fails with one
# file:line:column message, a non-zero exit, and no output file left behind.
# Inputs: -DBASALT=<binary> -DSOURCE_DIR=<repo> -DWORK=<scratch directory>

file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
set(failures 0)

function(fail msg)
  message(SEND_ERROR "FAIL: ${msg}")
endfunction()

# A good scene: tiny, quick on lavapipe and on the CPU.
file(WRITE ${WORK}/good.pbrt [=[
LookAt 0 0 -5  0 0 0  0 1 0
Camera "perspective" "float fov" [ 40 ]
Film "rgb" "integer xresolution" [ 32 ] "integer yresolution" [ 24 ] "string filename" "film.exr"
  "bool savefp16" false
Sampler "independent" "integer pixelsamples" [ 4 ]
WorldBegin
LightSource "point" "rgb I" [ 10 10 10 ] "point3 from" [ 0 3 -3 ]
Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]
Shape "sphere" "float radius" [ 1 ]
]=])

foreach(device lavapipe cpu)
  execute_process(COMMAND ${BASALT} ${WORK}/good.pbrt --device ${device} --spp 2 --seed 3
                          -o ${WORK}/good-${device}.exr -o ${WORK}/good-${device}.png
                          --stats ${WORK}/stats-${device}.json
                  RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_VARIABLE out)
  if(NOT rc EQUAL 0)
    fail("good scene on ${device}: exit ${rc}: ${err}")
  endif()
  foreach(f good-${device}.exr good-${device}.png stats-${device}.json)
    if(NOT EXISTS ${WORK}/${f})
      fail("good scene on ${device}: ${f} not written")
    endif()
  endforeach()
  # The unused Film parameter is a warning with its location, not an error.
  if(NOT err MATCHES "good\\.pbrt:4:[0-9]+: warning:.*savefp16")
    fail("good scene on ${device}: no located warning for savefp16: ${err}")
  endif()
  file(READ ${WORK}/stats-${device}.json json)
  foreach(key device driver width height spp seconds_parse seconds_bvh seconds_upload
              seconds_pipeline seconds_render samples_per_second rays_per_second
              peak_rss_bytes table_bytes wave_bytes features)
    string(JSON value ERROR_VARIABLE jerr GET "${json}" ${key})
    if(jerr)
      fail("stats on ${device}: key ${key} missing: ${jerr}")
    endif()
  endforeach()
  # The time to the first pass is counted from the start of the command: positive, and not
  # less than the parse it includes.
  string(JSON t_first ERROR_VARIABLE jerr GET "${json}" seconds_to_first_pass)
  string(JSON t_parse GET "${json}" seconds_parse)
  if(jerr OR NOT t_first GREATER 0 OR NOT t_first GREATER_EQUAL t_parse)
    fail("stats on ${device}: seconds_to_first_pass '${t_first}' (parse ${t_parse}) ${jerr}")
  endif()
  string(JSON w GET "${json}" width)
  string(JSON spp GET "${json}" spp)
  string(JSON f0 GET "${json}" features 0)
  if(NOT w EQUAL 32 OR NOT spp EQUAL 2 OR f0 STREQUAL "")
    fail("stats on ${device}: width ${w}, spp ${spp}, first feature '${f0}'")
  endif()
  # The Vulkan render reports its specialised shader build; a diffuse-only scene gets "lean".
  string(JSON variant ERROR_VARIABLE jerr GET "${json}" shader_variant)
  if(device STREQUAL "lavapipe" AND NOT variant STREQUAL "lean")
    fail("stats on lavapipe: shader_variant '${variant}' (${jerr}), expected lean")
  elseif(device STREQUAL "cpu" AND NOT jerr)
    fail("stats on cpu: shader_variant '${variant}' reported for the CPU reference")
  endif()
  # ... and, without textures, its plain build (pruned at build time).
  string(JSON plain ERROR_VARIABLE jerr GET "${json}" shader_plain)
  if(device STREQUAL "lavapipe" AND NOT plain STREQUAL "ON")
    fail("stats on lavapipe: shader_plain '${plain}' (${jerr}), expected true")
  endif()
endforeach()

# A scene with a conductor needs more than the lean megakernel: untextured, it renders through
# the full megakernel by default (shader_variant "full"), with --pipeline wavefront through the
# wavefront stages ("wavefront"); a coated diffuse (a layered material) gets the wavefront by
# default (docs/performance.md, eleventh session).
file(READ ${WORK}/good.pbrt good_text)
string(REPLACE [=[Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]]=]
               [=[Material "conductor" "float roughness" [ 0.2 ]]=] metal_text "${good_text}")
file(WRITE ${WORK}/metal.pbrt "${metal_text}")
string(REPLACE [=[Material "diffuse" "rgb reflectance" [ 0.5 0.5 0.5 ]]=]
               [=[Material "coateddiffuse" "float roughness" [ 0.2 ]]=] coated_text "${good_text}")
file(WRITE ${WORK}/coated.pbrt "${coated_text}")
foreach(run "metal;;full" "metal;--pipeline;wavefront;wavefront" "coated;;wavefront")
  list(GET run 0 scene)
  list(LENGTH run n)
  math(EXPR last "${n} - 1")
  list(GET run ${last} expected)
  set(args "")
  if(n EQUAL 4)
    list(GET run 1 opt)
    list(GET run 2 value)
    set(args ${opt} ${value})
  endif()
  execute_process(COMMAND ${BASALT} ${WORK}/${scene}.pbrt --device lavapipe --spp 1 --quiet
                          ${args} -o ${WORK}/${scene}.exr --stats ${WORK}/stats-${scene}.json
                  RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    fail("${scene} scene ${args} on lavapipe: exit ${rc}: ${err}")
  else()
    file(READ ${WORK}/stats-${scene}.json json)
    string(JSON variant ERROR_VARIABLE jerr GET "${json}" shader_variant)
    if(NOT variant STREQUAL expected)
      fail("${scene} scene ${args}: shader_variant '${variant}' (${jerr}), expected ${expected}")
    endif()
  endif()
endforeach()

# Without -o the Film filename is used (relative to the working directory).
execute_process(COMMAND ${BASALT} ${WORK}/good.pbrt --device cpu --spp 1 --quiet
                WORKING_DIRECTORY ${WORK} RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT EXISTS ${WORK}/film.exr)
  fail("Film filename default: exit ${rc}: ${err}")
endif()

# bad_case(name expected-location-regex scene-text): must fail with that location and
# leave no output file (nor a temporary one).
function(bad_case name where text)
  file(WRITE ${WORK}/${name}.pbrt "${text}")
  execute_process(COMMAND ${BASALT} ${WORK}/${name}.pbrt --device cpu --quiet
                          -o ${WORK}/${name}.exr
                  RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_VARIABLE out)
  if(rc EQUAL 0)
    fail("${name}: exit 0")
  endif()
  if(NOT err MATCHES "${where}: error: ")
    fail("${name}: message does not name ${where}: ${err}")
  endif()
  file(GLOB left ${WORK}/${name}.exr*)
  if(left)
    fail("${name}: output left behind: ${left}")
  endif()
endfunction()

set(head "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\nWorldBegin\n")
set(sphere "Shape \"sphere\"\n")
bad_case(unknown_directive "unknown_directive\\.pbrt:3:1" "${head}Frobnicate 1 2 3\n${sphere}")
bad_case(wrong_type "wrong_type\\.pbrt:1:[0-9]+"
         "Camera \"perspective\" \"string fov\" \"wide\"\nWorldBegin\n${sphere}")
bad_case(unterminated "unterminated\\.pbrt:3:[0-9]+" "${head}Material \"diffuse\n${sphere}")
bad_case(malformed_number "malformed_number\\.pbrt:3:[0-9]+"
         "${head}Shape \"sphere\" \"float radius\" [ 1.2.3 ]\n")
bad_case(negative_resolution "negative_resolution\\.pbrt:1:[0-9]+"
         "Film \"rgb\" \"integer xresolution\" [ -5 ]\nWorldBegin\n${sphere}")
bad_case(missing_include "missing_include\\.pbrt:3:[0-9]+" "${head}Include \"nowhere.pbrt\"\n")
bad_case(missing_ply "missing_ply\\.pbrt:3:[0-9]+"
         "${head}Shape \"plymesh\" \"string filename\" \"nowhere.ply\"\n")
bad_case(unknown_material "unknown_material\\.pbrt:3:[0-9]+"
         "${head}Material \"velvet\"\n${sphere}")
bad_case(empty_scene "empty_scene\\.pbrt(:[0-9]+:[0-9]+)?" "# nothing here\n")
# Materials (docs/materials.md): refused kinds, undefined mix names, unreadable measured data.
bad_case(hair_material "hair_material\\.pbrt:3:1" "${head}Material \"hair\"\n${sphere}")
bad_case(mix_undefined "mix_undefined\\.pbrt:3:16"
         "${head}Material \"mix\" \"string materials\" [\"a\" \"b\"]\n${sphere}")
bad_case(measured_missing "measured_missing\\.pbrt:3:21"
         "${head}Material \"measured\" \"string filename\" \"none.binary\"\n${sphere}")

# --mix: a nested pbrt-v4 mix renders stochastically (auto, stochastic) and is refused,
# with the location of the mix, when weighted mixes are forced.
set(mixes "MakeNamedMaterial \"a\" \"string type\" \"diffuse\"
MakeNamedMaterial \"b\" \"string type\" \"conductor\"
MakeNamedMaterial \"ab\" \"string type\" \"mix\" \"string materials\" [\"a\" \"b\"]
Material \"mix\" \"string materials\" [\"ab\" \"a\"]
")
file(WRITE ${WORK}/mix.pbrt "${head}${mixes}${sphere}")
foreach(mode auto stochastic)
  execute_process(COMMAND ${BASALT} ${WORK}/mix.pbrt --device cpu --quiet --spp 1 --mix ${mode}
                          -o ${WORK}/mix-${mode}.exr RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 0 OR NOT EXISTS ${WORK}/mix-${mode}.exr)
    fail("--mix ${mode}: exit ${rc}: ${err}")
  endif()
endforeach()
execute_process(COMMAND ${BASALT} ${WORK}/mix.pbrt --device cpu --quiet --mix weighted
                        -o ${WORK}/mix-weighted.exr RESULT_VARIABLE rc ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT err MATCHES "mix\\.pbrt:6:1: error: a weighted \\(pbrt-v3\\) mix cannot contain another mix"
   OR EXISTS ${WORK}/mix-weighted.exr)
  fail("--mix weighted on nested mixes: exit ${rc}: ${err}")
endif()
execute_process(COMMAND ${BASALT} ${WORK}/mix.pbrt --device cpu --mix sometimes
                RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_VARIABLE out)
if(NOT rc EQUAL 2)
  fail("--mix sometimes: exit ${rc} (expected 2, a bad command line)")
endif()

# Texture quality knobs (docs/textures.md): in force in --stats, checked values.
execute_process(COMMAND ${BASALT} ${SOURCE_DIR}/scenes/textures-procedural.pbrt --device cpu
                --quiet --spp 1 --texture-filter trilinear --noise-octaves 3
                --stats ${WORK}/knobs.json -o ${WORK}/knobs.exr RESULT_VARIABLE rc ERROR_VARIABLE err)
file(READ ${WORK}/knobs.json knobs)
if(NOT rc EQUAL 0 OR NOT knobs MATCHES "\"texture_filter\": \"trilinear\""
   OR NOT knobs MATCHES "\"noise_octave_cap\": \"3\"")
  fail("texture knobs: exit ${rc}: ${err} ${knobs}")
endif()
execute_process(COMMAND ${BASALT} ${SOURCE_DIR}/scenes/textures-procedural.pbrt --device cpu
                --texture-filter sharp -o ${WORK}/knobs-bad.exr RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 2 OR EXISTS ${WORK}/knobs-bad.exr)
  fail("--texture-filter sharp: exit ${rc} (expected 2): ${err}")
endif()

# Bump and displacement knobs (docs/bump-spec.md 4.5): in force in --stats; the edge scale
# changes the displaced mesh's triangle count.
execute_process(COMMAND ${BASALT} ${SOURCE_DIR}/scenes/displacement.pbrt --device cpu
                --quiet --spp 1 --bump-differences central --bump-dndu off --bump-step 0.001
                --shading-normal-rule pbrt-v4 --maxdepth 3 --roulette off --mis balance
                --stats ${WORK}/bump.json -o ${WORK}/bump.exr RESULT_VARIABLE rc ERROR_VARIABLE err)
file(READ ${WORK}/bump.json bump)
if(NOT rc EQUAL 0 OR NOT bump MATCHES "\"bump_differences\": \"central\""
   OR NOT bump MATCHES "\"bump_dndu\": \"off\"" OR NOT bump MATCHES "\"bump_step\": \"0.001"
   OR NOT bump MATCHES "\"shading_normal_rule\": \"pbrt-v4\""
   OR NOT bump MATCHES "\"maxdepth\": \"3\"" OR NOT bump MATCHES "\"roulette\": \"off\""
   OR NOT bump MATCHES "\"mis\": \"balance\"")
  fail("bump knobs: exit ${rc}: ${err} ${bump}")
endif()
string(JSON tris1 GET "${bump}" triangles)
execute_process(COMMAND ${BASALT} ${SOURCE_DIR}/scenes/displacement.pbrt --device cpu
                --quiet --spp 1 --displacement-edge-scale 0.5
                --stats ${WORK}/edge.json -o ${WORK}/edge.exr RESULT_VARIABLE rc ERROR_VARIABLE err)
file(READ ${WORK}/edge.json edge)
string(JSON tris2 GET "${edge}" triangles)
if(NOT rc EQUAL 0 OR NOT tris2 GREATER tris1 OR NOT edge MATCHES "\"displacement_edge_scale\": \"0.5")
  fail("--displacement-edge-scale 0.5: exit ${rc}, ${tris2} triangles (default ${tris1}): ${err}")
endif()

# Sampler, light-sampler, layered and time-only knobs (issue 10): in force in --stats.
execute_process(COMMAND ${BASALT} ${SOURCE_DIR}/scenes/coated-rough.pbrt --device cpu --quiet
                --spp 1 --sampler halton --light-sampler uniform --layered-mis pbrt-v4
                --coated-nsamples 2 --coated-maxdepth 4 --bvh-bins 8 --bvh-leaf 4
                --pipeline all --stats ${WORK}/knobs.json -o ${WORK}/knobs.exr
                RESULT_VARIABLE rc ERROR_VARIABLE err)
file(READ ${WORK}/knobs.json knobs)
if(NOT rc EQUAL 0 OR NOT knobs MATCHES "\"sampler\": \"halton permutedigits\""
   OR NOT knobs MATCHES "\"light_sampler\": \"uniform\""
   OR NOT knobs MATCHES "\"layered_mis\": \"pbrt-v4\""
   OR NOT knobs MATCHES "\"coated_nsamples\": \"2\"" OR NOT knobs MATCHES "\"coated_maxdepth\": \"4\""
   OR NOT knobs MATCHES "\"bvh_bins\": \"8\"" OR NOT knobs MATCHES "\"bvh_leaf\": \"4\""
   OR NOT knobs MATCHES "\"pipeline\": \"all\"")
  fail("sampler and table knobs: exit ${rc}: ${err} ${knobs}")
endif()
# zsobol takes a power-of-two sample count, as pbrt-v4: 6 becomes 4, with a warning.
execute_process(COMMAND ${BASALT} ${WORK}/good.pbrt --device cpu --quiet --spp 6 --sampler zsobol
                --stats ${WORK}/zsobol.json -o ${WORK}/zsobol.exr RESULT_VARIABLE rc ERROR_VARIABLE err)
file(READ ${WORK}/zsobol.json zs)
if(NOT rc EQUAL 0 OR NOT zs MATCHES "\"spp\": 4" OR NOT err MATCHES "power-of-two")
  fail("--sampler zsobol --spp 6: exit ${rc}: ${err} ${zs}")
endif()
# sobol and pmj02bn (every sampler pbrt-v4 names): in force in --stats; pmj02bn warns below a
# power of 4 and refuses more than 65536 samples per pixel (as pbrt-v4), writing nothing.
execute_process(COMMAND ${BASALT} ${WORK}/good.pbrt --device cpu --quiet --spp 4 --sampler sobol
                --stats ${WORK}/sobol.json -o ${WORK}/sobol.exr RESULT_VARIABLE rc ERROR_VARIABLE err)
file(READ ${WORK}/sobol.json so)
if(NOT rc EQUAL 0 OR NOT so MATCHES "\"sampler\": \"sobol fastowen\"" OR NOT EXISTS ${WORK}/sobol.exr)
  fail("--sampler sobol: exit ${rc}: ${err} ${so}")
endif()
execute_process(COMMAND ${BASALT} ${WORK}/good.pbrt --device cpu --quiet --spp 8 --sampler pmj02bn
                --stats ${WORK}/pmj.json -o ${WORK}/pmj.exr RESULT_VARIABLE rc ERROR_VARIABLE err)
file(READ ${WORK}/pmj.json pm)
if(NOT rc EQUAL 0 OR NOT pm MATCHES "\"sampler\": \"pmj02bn\"" OR NOT pm MATCHES "\"spp\": 8"
   OR NOT err MATCHES "power of 4")
  fail("--sampler pmj02bn --spp 8: exit ${rc}: ${err} ${pm}")
endif()
execute_process(COMMAND ${BASALT} ${WORK}/good.pbrt --device cpu --quiet --spp 65537 --sampler pmj02bn
                -o ${WORK}/pmj-big.exr RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 1 OR NOT err MATCHES "at most 65536" OR EXISTS ${WORK}/pmj-big.exr)
  fail("--sampler pmj02bn --spp 65537: exit ${rc} (expected 1): ${err}")
endif()
# Bad values of every quality knob above are a bad command line (exit 2), nothing written.
foreach(bad "--bump-step;0" "--bump-step;-1" "--bump-step;fine" "--bump-differences;backward"
            "--bump-dndu;maybe" "--displacement-edge-scale;0" "--shading-normal-rule;pbrt-v3"
            "--maxdepth;-1" "--roulette;sometimes" "--roulette;-2" "--mis;mixed"
            "--sampler;sobolev" "--light-sampler;random" "--layered-mis;pbrt-v3"
            "--pipeline;some" "--bvh-bins;1" "--bvh-bins;65" "--bvh-leaf;1" "--bvh-leaf;17"
            "--coated-nsamples;0" "--coated-maxdepth;-3")
  execute_process(COMMAND ${BASALT} ${WORK}/good.pbrt --device cpu ${bad} -o ${WORK}/knob-bad.exr
                  RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 2 OR EXISTS ${WORK}/knob-bad.exr)
    fail("${bad}: exit ${rc} (expected 2): ${err}")
  endif()
endforeach()

# A missing scene file and an unsupported output format fail before any rendering.
execute_process(COMMAND ${BASALT} ${WORK}/does-not-exist.pbrt -o ${WORK}/x.exr
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT err MATCHES "does-not-exist\\.pbrt" OR EXISTS ${WORK}/x.exr)
  fail("missing scene file: exit ${rc}: ${err}")
endif()
execute_process(COMMAND ${BASALT} ${WORK}/good.pbrt --device cpu -o ${WORK}/x.jpg
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(rc EQUAL 0 OR EXISTS ${WORK}/x.jpg)
  fail("unsupported output format: exit ${rc}: ${err}")
endif()
execute_process(COMMAND ${BASALT} --help RESULT_VARIABLE rc OUTPUT_VARIABLE out)
if(NOT rc EQUAL 0 OR NOT out MATCHES "--spp" OR NOT out MATCHES "--mix")
  fail("--help: exit ${rc}")
endif()

# basalt study (issue 10): a small sweep of spp and every available knob on both devices,
# within a time budget. The budget is the whole command's: the sweep skips what would
# overrun, so the wall time stays under it; the charts need python3-matplotlib.
set(knob_names spp maxdepth roulette mis mix texture-filter noise-octaves noise-precision
    bump-differences bump-dndu sampler light-sampler pipeline bvh-bins bvh-leaf
    coated-nsamples coated-maxdepth layered-mis)
execute_process(COMMAND /usr/bin/python3 -c "import matplotlib" RESULT_VARIABLE py_rc
                OUTPUT_QUIET ERROR_QUIET)
if(NOT py_rc EQUAL 0)
  fail("basalt study: /usr/bin/python3 cannot import matplotlib: install python3-matplotlib "
       "(cmake/install-deps.sh)")
endif()
set(budget 50)
string(TIMESTAMP t0 "%s" UTC)
execute_process(COMMAND ${BASALT} study ${WORK}/good.pbrt --devices cpu,lavapipe --spp-max 4
                        --seeds 2 --budget ${budget} --out ${WORK}/study
                RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_VARIABLE out)
string(TIMESTAMP t1 "%s" UTC)
math(EXPR wall "${t1} - ${t0}")
if(NOT rc EQUAL 0)
  fail("basalt study: exit ${rc}: ${err}")
endif()
if(err MATCHES "python3-matplotlib")
  fail("basalt study: no charts, python3-matplotlib is missing: ${err}")
endif()
if(NOT wall LESS budget)
  fail("basalt study: ${wall} s, over its budget of ${budget} s")
endif()
foreach(f study.json study.csv report.md chart-spp.png)
  if(NOT EXISTS ${WORK}/study/${f})
    fail("basalt study: ${f} not written")
  endif()
endforeach()
# Within the budget a chart may be left out (on a loaded machine, or while lavapipe compiles
# its pipelines cold), but then report.md names it; the spp chart comes first and always fits.
set(charts chart-cpu.png chart-lavapipe.png chart-cpu-ssim.png chart-lavapipe-ssim.png)
if(EXISTS ${WORK}/study/report.md)
  file(READ ${WORK}/study/report.md report_budgeted)
  foreach(f ${charts})
    if(NOT EXISTS ${WORK}/study/${f} AND NOT report_budgeted MATCHES "left out for the time budget[^\n]*${f}")
      fail("basalt study: ${f} neither written nor named as left out for the time budget")
    endif()
  endforeach()
endif()
# Without a deadline, tools/study_report.py draws every chart from the same study.json.
execute_process(COMMAND /usr/bin/python3 ${SOURCE_DIR}/tools/study_report.py ${WORK}/study/study.json
                RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  fail("study_report.py without a deadline: exit ${rc}: ${err}")
endif()
foreach(f ${charts})
  if(NOT EXISTS ${WORK}/study/${f})
    fail("study_report.py without a deadline: ${f} not written")
  endif()
endforeach()
if(EXISTS ${WORK}/study/study.json AND EXISTS ${WORK}/study/report.md)
  file(READ ${WORK}/study/study.json study_json)
  file(READ ${WORK}/study/report.md report)
  foreach(name ${knob_names})
    if(NOT study_json MATCHES "\"name\": \"${name}\"")
      fail("basalt study: knob ${name} missing from study.json")
    endif()
    if(NOT report MATCHES "## ${name} ")
      fail("basalt study: knob ${name} missing from report.md")
    endif()
  endforeach()
  string(JSON done GET "${study_json}" runs done)
  string(JSON e0 GET "${study_json}" points 0 rel_mse_mean)
  if(done LESS 10 OR NOT e0 GREATER 0)
    fail("basalt study: ${done} runs done, first relMSE ${e0}")
  endif()
endif()
# A knob that does not exist is a bad command line; a reference of the wrong size is bad input.
execute_process(COMMAND ${BASALT} study ${WORK}/good.pbrt --knobs maxdepth,nonexistent
                        --out ${WORK}/study-bad RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 2 OR NOT err MATCHES "unknown knob 'nonexistent'")
  fail("basalt study --knobs nonexistent: exit ${rc} (expected 2): ${err}")
endif()
string(REPLACE "[ 32 ]" "[ 16 ]" small_text "${good_text}")
file(WRITE ${WORK}/small.pbrt "${small_text}")
execute_process(COMMAND ${BASALT} ${WORK}/small.pbrt --device cpu --spp 1 --quiet
                        -o ${WORK}/small.exr RESULT_VARIABLE rc ERROR_VARIABLE err)
execute_process(COMMAND ${BASALT} study ${WORK}/good.pbrt --reference ${WORK}/small.exr
                        --out ${WORK}/study-bad RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 1 OR NOT err MATCHES "reference .*small\\.exr is 16x24, the scene renders 32x24")
  fail("basalt study --reference of the wrong size: exit ${rc} (expected 1): ${err}")
endif()
# A given reference of the right size is used and named in the report (it once left the
# study's reference record empty and the report script failed).
execute_process(COMMAND ${BASALT} ${WORK}/good.pbrt --device cpu --spp 4 --quiet
                        -o ${WORK}/good-ref.exr RESULT_VARIABLE rc ERROR_VARIABLE err)
execute_process(COMMAND ${BASALT} study ${WORK}/good.pbrt --reference ${WORK}/good-ref.exr
                        --knobs spp --spp-max 2 --seeds 1 --devices cpu --quiet
                        --out ${WORK}/study-given RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT EXISTS ${WORK}/study-given/report.md)
  fail("basalt study --reference (right size): exit ${rc}: ${err}")
else()
  file(READ ${WORK}/study-given/report.md given_report)
  if(NOT given_report MATCHES "good-ref\\.exr` \\(given\\)")
    fail("basalt study --reference: report.md does not name the given reference")
  endif()
endif()
