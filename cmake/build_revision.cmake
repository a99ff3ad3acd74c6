# The source revision a binary is built from, found on every build (not when
# CMake configures: a build after a commit, or after an edit, names what it
# compiled), written into a generated source only when it changed, so that a
# build with nothing new recompiles nothing:
#
#   cmake -DSOURCE_DIR=<repo> -DTEMPLATE=<source.in> -DOUTPUT=<source> -P build_revision.cmake
#
# The revision: `git describe --always --dirty --abbrev=12` of SOURCE_DIR
# (-dirty: the working tree has changes not committed, so the binary is not
# that commit's code); "unknown" without git or outside a clone (a source
# archive).
cmake_minimum_required(VERSION 3.25)

set(LOCKSTEP_GIT_REVISION "unknown")
find_package(Git QUIET)
if(GIT_FOUND AND EXISTS ${SOURCE_DIR}/.git)
  execute_process(COMMAND ${GIT_EXECUTABLE} -C ${SOURCE_DIR} describe --always --dirty --abbrev=12
                  OUTPUT_VARIABLE revision OUTPUT_STRIP_TRAILING_WHITESPACE
                  RESULT_VARIABLE git_status ERROR_QUIET)
  if(git_status EQUAL 0 AND NOT revision STREQUAL "")
    set(LOCKSTEP_GIT_REVISION "${revision}")
  endif()
endif()
# configure_file leaves OUTPUT untouched when its text would not change.
configure_file(${TEMPLATE} ${OUTPUT} @ONLY)
