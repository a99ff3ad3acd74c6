# cmake/build_revision.cmake on a scratch repository: "unknown" outside a
# clone; a commit's hash after it; -dirty with a change not committed; the
# next commit's hash at the next build; the file left untouched when nothing
# changed (so a build with nothing new recompiles nothing).
#
#   cmake -DSCRIPT=<cmake/build_revision.cmake> -DWORK=<scratch folder> -P build_revision_test.cmake
cmake_minimum_required(VERSION 3.25)
find_package(Git REQUIRED)

file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK}/repo)
file(WRITE ${WORK}/revision.in "@LOCKSTEP_GIT_REVISION@\n")
set(out ${WORK}/revision.txt)

function(revision_now result)
  execute_process(COMMAND ${CMAKE_COMMAND} -DSOURCE_DIR=${WORK}/repo -DTEMPLATE=${WORK}/revision.in -DOUTPUT=${out}
                          -P ${SCRIPT}
                  RESULT_VARIABLE status)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "build_revision.cmake failed: ${status}")
  endif()
  file(STRINGS ${out} text)
  set(${result} "${text}" PARENT_SCOPE)
endfunction()
function(git)
  execute_process(COMMAND ${GIT_EXECUTABLE} -C ${WORK}/repo -c user.name=test -c user.email=test@invalid
                          -c commit.gpgsign=false ${ARGN}
                  OUTPUT_VARIABLE ignored ERROR_VARIABLE ignored RESULT_VARIABLE status)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "git ${ARGN} failed: ${status}")
  endif()
endfunction()
function(head result)
  execute_process(COMMAND ${GIT_EXECUTABLE} -C ${WORK}/repo rev-parse --short=12 HEAD
                  OUTPUT_VARIABLE hash OUTPUT_STRIP_TRAILING_WHITESPACE)
  set(${result} "${hash}" PARENT_SCOPE)
endfunction()
function(expect what got wanted)
  if(NOT got STREQUAL wanted)
    message(FATAL_ERROR "${what}: got '${got}', wanted '${wanted}'")
  endif()
endfunction()

revision_now(found)
expect("outside a clone" "${found}" "unknown")

git(init -q)
file(WRITE ${WORK}/repo/a.txt "one\n")
git(add a.txt)
git(commit -q -m one)
head(first)
revision_now(found)
expect("after the first commit" "${found}" "${first}")

file(TIMESTAMP ${out} before "%Y-%m-%dT%H:%M:%S.%f")
execute_process(COMMAND ${CMAKE_COMMAND} -E sleep 1.1)
revision_now(found)
file(TIMESTAMP ${out} after "%Y-%m-%dT%H:%M:%S.%f")
expect("a build with nothing new leaves the file alone" "${after}" "${before}")

file(WRITE ${WORK}/repo/a.txt "two\n")
revision_now(found)
expect("with a change not committed" "${found}" "${first}-dirty")

git(commit -q -a -m two)
head(second)
revision_now(found)
expect("after the next commit" "${found}" "${second}")
