# The layering of lockstep's folders, checked on every build: a header or
# source may include lockstep headers only from the folders its own folder
# depends on (the same edges the CMake targets link). A back-edge (sync/
# including kernels/, probes/ including the harness, ...) fails the build
# with the file, the line and the rule it breaks.
#
#   cmake -DSOURCE_DIR=<repo> -DSTAMP=<file> -P check_layering.cmake
#
cmake_minimum_required(VERSION 3.25)

# folder (relative to the repository)  -> folders it may include from
set(allowed_platform        platform)
set(allowed_kernels         kernels)
set(allowed_sync            sync platform)
set(allowed_layouts         layouts platform)
# The composed step: kernels/parallel_step.hpp and parallel_exchange.hpp
# (target lockstep::step) reach into sync/ and layouts/.
set(allowed_step            kernels sync layouts platform)
set(allowed_bench/probes    bench/probes kernels sync layouts platform)
set(allowed_bench/harness   bench/harness bench/probes kernels sync layouts platform)
set(allowed_distributed     distributed kernels sync layouts platform)
set(allowed_bench/cli       bench/cli bench/harness bench/probes distributed kernels sync layouts platform)
set(step_files kernels/parallel_step.hpp kernels/parallel_exchange.hpp)

set(violations "")
foreach(folder platform kernels sync layouts distributed bench/probes bench/harness bench/cli)
  file(GLOB files RELATIVE ${SOURCE_DIR} ${SOURCE_DIR}/${folder}/*.hpp ${SOURCE_DIR}/${folder}/*.cpp
       ${SOURCE_DIR}/${folder}/*.h ${SOURCE_DIR}/${folder}/*.c)
  foreach(file ${files})
    set(rule ${folder})
    if(file IN_LIST step_files)
      set(rule step)
    endif()
    file(STRINGS ${SOURCE_DIR}/${file} includes REGEX "^#include \"")
    foreach(line ${includes})
      string(REGEX REPLACE "^#include \"([^\"]+)\".*" "\\1" included "${line}")
      string(REGEX MATCH "^(bench/[a-z_]+|[a-z_]+)/" prefix "${included}")
      string(REGEX REPLACE "/$" "" prefix "${prefix}")
      if(prefix STREQUAL "" OR NOT IS_DIRECTORY ${SOURCE_DIR}/${prefix})
        continue()  # a header of the same folder by a bare name, or generated
      endif()
      if(NOT prefix IN_LIST allowed_${rule})
        string(APPEND violations "  ${file}: #include \"${included}\" (${rule} may include from: ${allowed_${rule}})\n")
      endif()
    endforeach()
  endforeach()
endforeach()

if(violations)
  message(FATAL_ERROR "lockstep layering broken (cmake/check_layering.cmake):\n${violations}")
endif()
file(WRITE ${STAMP} "layering ok\n")
