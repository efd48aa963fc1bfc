# Writes OUT (a header) with basalt's version and the commit being built, at build time, so
# that `basalt --version` and `basalt study` reports name the code actually compiled (a tree
# with uncommitted changes is marked "-dirty"). Rewrites OUT only when its text changes.
# Inputs: -DSRC=<source dir> -DOUT=<header> -DVERSION=<project version>
execute_process(COMMAND git -C ${SRC} rev-parse --short=12 HEAD
  OUTPUT_VARIABLE commit OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET RESULT_VARIABLE rc)
if(NOT rc EQUAL 0 OR commit STREQUAL "")
  set(commit unknown)
else()
  execute_process(COMMAND git -C ${SRC} diff --quiet HEAD -- host shaders CMakeLists.txt cmake
    RESULT_VARIABLE dirty ERROR_QUIET)
  if(NOT dirty EQUAL 0)
    string(APPEND commit "-dirty")
  endif()
endif()
set(text "// Written by cmake/version.cmake at build time.\n#pragma once\n#define BASALT_VERSION \"${VERSION}\"\n#define BASALT_GIT_COMMIT \"${commit}\"\n")
if(EXISTS ${OUT})
  file(READ ${OUT} old)
endif()
if(NOT old STREQUAL text)
  file(WRITE ${OUT} "${text}")
endif()
