# Runs one Promela model through Spin for CTest (cmake -P run_model.cmake).
#
#   cmake -DSPIN=/usr/bin/spin -DCC=/usr/bin/gcc [-DLAUNCHER=ccache]
#         -DMODEL=<source>/tests/spin/futex_spin.pml -DWORK_DIR=<build>/tests/spin/<test>
#         [-DDEFINES=PARTICIPANTS=3,PHASES=3] -DCHECK=safety|liveness
#         -DEXPECT=verified|counterexample [-DERROR=<regex>]
#         [-DOPTIMIZE=ON] [-DSHORTEST=ON] -P run_model.cmake
#
# It copies the model into WORK_DIR, emptied first (pan writes its trail next
# to the model: the source tree stays clean), generates pan there with
# `spin -a`, compiles it and runs it:
#   CHECK=safety    -DSAFETY -DNOCLAIM: assertions and invalid end states
#                   (a participant blocked forever when the others are done);
#   CHECK=liveness  the model's LTL claim every_participant_proceeds, searched
#                   for acceptance cycles under weak fairness (pan -a -f); the
#                   model's assertions are checked on the way.
# EXPECT=verified passes on `errors: 0` from a complete search (no depth limit
# hit, memory limit not reached). EXPECT=counterexample passes when pan
# reports an error (matching ERROR, a regex, if given) and writes a trail; it
# then replays the trail and prints the model's narration of it.
# Any other outcome is one FATAL_ERROR with pan's output.
cmake_minimum_required(VERSION 3.25)

foreach(required SPIN CC MODEL WORK_DIR CHECK EXPECT)
  if(NOT DEFINED ${required} OR "${${required}}" STREQUAL "")
    message(FATAL_ERROR "run_model.cmake: ${required} is not set")
  endif()
endforeach()
if(NOT CHECK MATCHES "^(safety|liveness)$")
  message(FATAL_ERROR "run_model.cmake: CHECK must be safety or liveness, not '${CHECK}'")
endif()
if(NOT EXPECT MATCHES "^(verified|counterexample)$")
  message(FATAL_ERROR "run_model.cmake: EXPECT must be verified or counterexample, not '${EXPECT}'")
endif()

# A fresh scratch directory with a copy of the model.
file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}")
file(COPY "${MODEL}" DESTINATION "${WORK_DIR}")
get_filename_component(model "${MODEL}" NAME)

set(spin_defines "")
if(DEFINES)
  string(REPLACE "," ";" define_list "${DEFINES}")
  foreach(define IN LISTS define_list)
    list(APPEND spin_defines "-D${define}")
  endforeach()
endif()

function(run what)
  execute_process(COMMAND ${ARGN}
    WORKING_DIRECTORY "${WORK_DIR}"
    RESULT_VARIABLE status OUTPUT_VARIABLE output ERROR_VARIABLE output)
  set(${what}_status "${status}" PARENT_SCOPE)
  set(${what}_output "${output}" PARENT_SCOPE)
endfunction()

run(generate "${SPIN}" ${spin_defines} -a "${model}")
if(NOT generate_status EQUAL 0)
  message(FATAL_ERROR "spin -a ${model} ${DEFINES} failed:\n${generate_output}")
endif()

# pan's options, compiled in:
#  -O2 / -O0      OPTIMIZE (searches of a million states and more): -O2
#                 halves pan's time but costs gcc a second more than -O0,
#                 which is more than the smaller searches take in all;
#  MEMLIM=1024    pan stops at 1 GB instead of swamping a machine shared by
#                 several engineers (the largest model here needs ~0.3 GB);
#  VECTORSZ=512   the largest state vector here is under 100 bytes;
#  SAFETY/NOCLAIM a safety search without the LTL claim (CHECK=safety);
#  REACH          needed by -i (shortest trail), which SHORTEST asks for.
# -w: generated code, whose warnings (gcc 12's -Wstringop-overflow on pan.b)
# are Spin's business, not ours.
if(OPTIMIZE)
  set(compile_flags -O2)
else()
  set(compile_flags -O0)
endif()
list(APPEND compile_flags -w -DMEMLIM=1024 -DVECTORSZ=512)
# pan: -n no list of unreached states; -m a depth limit far above any model's
# (a search that hits it is reported incomplete); -w22 a hash table of 2^22
# slots (32 MB), enough for the two million states of the largest model.
set(pan_flags -n -m1000000 -w22)
if(CHECK STREQUAL "safety")
  list(APPEND compile_flags -DSAFETY -DNOCLAIM)
else()
  list(APPEND pan_flags -a -f)
endif()
if(SHORTEST)
  list(APPEND compile_flags -DREACH)
  list(APPEND pan_flags -i)
endif()

# Compile and link apart: ccache (LAUNCHER, when the build uses it) caches a
# compile, not a compile-and-link, and pan.c is the same from run to run.
run(compile ${LAUNCHER} "${CC}" ${compile_flags} -c -o pan.o pan.c)
if(compile_status EQUAL 0)
  run(compile "${CC}" -o pan pan.o)
endif()
if(NOT compile_status EQUAL 0)
  message(FATAL_ERROR "compiling pan for ${model} failed:\n${compile_output}")
endif()

run(verify "${WORK_DIR}/pan" ${pan_flags})
set(pan_output "${verify_output}")

# The summary: what was searched, how far, how fast.
set(summary "")
foreach(pattern
    "State-vector [^\n]*"
    "[0-9.e+]+ states, stored[^\n]*"
    "[0-9.e+]+ transitions[^\n]*"
    "[0-9.]+[\t ]+total actual memory usage"
    "pan: elapsed time [^\n]*")
  if(pan_output MATCHES "(${pattern})")
    string(STRIP "${CMAKE_MATCH_1}" line)
    string(APPEND summary "  ${line}\n")
  endif()
endforeach()
set(title "${model} [${DEFINES}] ${CHECK}")

if(NOT pan_output MATCHES "errors: ([0-9]+)")
  message(FATAL_ERROR "${title}: pan did not finish (status ${verify_status}):\n${pan_output}")
endif()
set(errors "${CMAKE_MATCH_1}")
if(pan_output MATCHES "(pan: reached -DMEMLIM bound|pan: out of memory)")
  message(FATAL_ERROR "${title}: the search ran out of memory (raise MEMLIM or shrink the model):\n${pan_output}")
endif()

if(EXPECT STREQUAL "verified")
  if(NOT errors EQUAL 0)
    message(STATUS "${title}: ${errors} error(s) where none was expected:\n${pan_output}")
    if(EXISTS "${WORK_DIR}/${model}.trail")
      run(replay "${SPIN}" ${spin_defines} -t -p "${model}")
      message(STATUS "trail:\n${replay_output}")
    endif()
    message(FATAL_ERROR "${title}: Spin found a counterexample (trail above, and in ${WORK_DIR})")
  endif()
  if(pan_output MATCHES "max search depth too small")
    message(FATAL_ERROR "${title}: the search hit its depth limit, so it is incomplete:\n${pan_output}")
  endif()
  message(STATUS "${title}: verified, errors: 0\n${summary}")
  return()
endif()

# EXPECT=counterexample.
if(errors EQUAL 0 OR NOT EXISTS "${WORK_DIR}/${model}.trail")
  message(FATAL_ERROR "${title}: Spin found no counterexample where one is expected (the model's "
                      "deliberate defect is gone, or the property no longer bites):\n${pan_output}")
endif()
string(REGEX MATCH "pan:[0-9]+: [^\n]*" first_error "${pan_output}")
if(ERROR AND NOT first_error MATCHES "${ERROR}")
  message(FATAL_ERROR "${title}: Spin found '${first_error}', not the expected '${ERROR}':\n${pan_output}")
endif()

# Replay the trail. The models narrate their steps with printf (which pan
# ignores), so the replay without -p reads as the interleaving; drop Spin's
# own lines about the never claim. The full statement-level trail is one
# `spin -t -p` away (printed below).
run(replay "${SPIN}" ${spin_defines} -t "${model}")
set(trail "\n${replay_output}")
string(REGEX REPLACE "\n(starting claim|Never claim moves|ltl |[ 0-9]+:\tproc  - )[^\n]*" "" trail "${trail}")
string(REGEX REPLACE "\n[ \t]*\n" "\n" trail "${trail}")
string(REGEX REPLACE "^\n+" "" trail "${trail}")  # keep the first line's indent: it names the process
list(JOIN spin_defines " " replay_defines)
message(STATUS "${title}: counterexample found, as expected: ${first_error}\n${summary}"
               "Trail (replay: cd ${WORK_DIR} && ${SPIN} ${replay_defines} -t -p ${model}):\n${trail}")
