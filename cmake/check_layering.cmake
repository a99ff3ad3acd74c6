# The layering of lockstep's folders, checked on every build: a header or
# source may include lockstep headers only from the folders its own folder
# depends on (the same edges the CMake targets link). A back-edge (sync/
# including kernels/, bench/results/ including bench/run/, ...) fails the build
# with the file, the line and the rule it breaks.
#
#   cmake -DSOURCE_DIR=<repo> -DSTAMP=<file> -P check_layering.cmake
#
# Every folder below the layered roots is checked, however deep: a file
# belongs to the deepest folder that has a rule here, and an included header
# to the deepest folder with a rule that holds it, so a file in a nested
# folder (bench/run/x/) is held to bench/run's rule. A folder with sources
# that no rule covers fails the build too: a new room gets its rule here.
cmake_minimum_required(VERSION 3.25)

# folder (relative to the repository)  -> folders it may include from
set(rule_folders platform kernels sync layouts distributed
                 bench/results bench/probes bench/probe_reports bench/delay bench/run bench/cli)
set(allowed_platform             platform)
set(allowed_kernels              kernels)
set(allowed_sync                 sync platform)
set(allowed_layouts              layouts platform)
# The composed step: kernels/parallel_step.hpp and parallel_exchange.hpp
# (target lockstep::step) reach into sync/ and layouts/.
set(allowed_step                 kernels sync layouts platform)
set(allowed_distributed          distributed kernels sync layouts platform)
# An entry's spec (bench/results/entry_spec.hpp) carries its model
# (kernels/model_choice.hpp), which every reader of the results reads.
set(allowed_bench/results        bench/results kernels platform)
set(allowed_bench/probes         bench/probes kernels sync layouts platform)
set(allowed_bench/probe_reports  bench/probe_reports bench/results bench/probes kernels sync layouts platform)
set(allowed_bench/delay          bench/delay bench/results bench/probes kernels sync layouts platform)
set(allowed_bench/run            bench/run bench/probe_reports bench/results bench/probes kernels sync layouts platform)
set(allowed_bench/cli            bench/cli bench/run bench/delay bench/probe_reports bench/results bench/probes
                                 distributed kernels sync layouts platform)
set(step_files kernels/parallel_step.hpp kernels/parallel_exchange.hpp)
# The roots whose every folder must have a rule (bench/ itself holds no sources).
set(layered_roots platform kernels sync layouts distributed bench)

# The deepest folder of rule_folders that holds `path` (a file or folder
# relative to the repository), or "" when none does.
function(owning_folder path out)
  set(best "")
  string(LENGTH "" best_length)
  foreach(folder ${rule_folders})
    string(LENGTH "${folder}/" length)
    string(SUBSTRING "${path}/" 0 ${length} head)
    if(head STREQUAL "${folder}/" AND length GREATER best_length)
      set(best ${folder})
      set(best_length ${length})
    endif()
  endforeach()
  set(${out} "${best}" PARENT_SCOPE)
endfunction()

set(violations "")
foreach(root ${layered_roots})
  file(GLOB_RECURSE files RELATIVE ${SOURCE_DIR} ${SOURCE_DIR}/${root}/*.hpp ${SOURCE_DIR}/${root}/*.cpp
       ${SOURCE_DIR}/${root}/*.h ${SOURCE_DIR}/${root}/*.c)
  foreach(file ${files})
    owning_folder(${file} folder)
    if(folder STREQUAL "")
      get_filename_component(directory ${file} DIRECTORY)
      string(APPEND violations "  ${file}: its folder ${directory} has no rule (add one to cmake/check_layering.cmake)\n")
      continue()
    endif()
    set(rule ${folder})
    if(file IN_LIST step_files)
      set(rule step)
    endif()
    file(STRINGS ${SOURCE_DIR}/${file} includes REGEX "^#include \"")
    foreach(line ${includes})
      string(REGEX REPLACE "^#include \"([^\"]+)\".*" "\\1" included "${line}")
      get_filename_component(included_directory ${included} DIRECTORY)
      if(included_directory STREQUAL "" OR NOT IS_DIRECTORY ${SOURCE_DIR}/${included_directory})
        continue()  # a header of the same folder by a bare name, a system header, or generated
      endif()
      owning_folder(${included} included_folder)
      if(included_folder STREQUAL "")
        continue()  # outside the layered folders (tests/ are not included by them)
      endif()
      if(NOT included_folder IN_LIST allowed_${rule})
        string(REPLACE ";" " " allowed_text "${allowed_${rule}}")
        string(APPEND violations "  ${file}: #include \"${included}\" (${rule} may include from: ${allowed_text})\n")
      endif()
    endforeach()
  endforeach()
endforeach()

if(violations)
  message(FATAL_ERROR "lockstep layering broken (cmake/check_layering.cmake):\n${violations}")
endif()
file(WRITE ${STAMP} "layering ok\n")
