# Every file a comment, test or page of lockstep cites must exist, checked on
# every build: a reader who clones the repository must be able to follow each
# citation. Fails the build with one line per missing file:
#
#   kernels/rk4.hpp:17 cites <the path>, which does not exist
#
#   cmake -DSOURCE_DIR=<repo> -DSTAMP=<file> -P check_citations.cmake
#
# What is scanned: the sources and pages under the repository's top-level
# folders (C and C++, CMake, Python, shell, Promela, Markdown, templates), the
# top-level README.md and CMakeLists.txt.
#
# What counts as a citation (anywhere in a file, comment or not):
#   * a path whose last part has an extension and whose first part is a
#     top-level folder of the repository (kernels/, sync/, ..., docs/), or a
#     folder beside the citing file (lockstep_reports/... in reports/), or
#     `./` / `../` (a Markdown link); it must name a file or folder relative
#     to the repository root or to the citing file's folder. A file that the
#     build generates from `<path>.in` (configure_file) counts as existing.
#     A glob or a placeholder (`reports/tests/test_*.py`,
#     `bench/cli/<command>.cpp`) must match at least one file.
#   * a bare name ending in `.md` (README.md): it must exist in the citing
#     file's folder or at the repository root.
# What does not: absolute paths (/proc/...), URLs (https://...), paths that
# start with a CMake variable (${CMAKE_CURRENT_BINARY_DIR}/...), paths under
# folders the repository does not have (build/, results/, a test's scratch
# files): those are not files of the repository.
cmake_minimum_required(VERSION 3.25)

set(top_folders kernels sync layouts platform bench distributed tests reports scripts cmake docs .ci)
set(patterns *.hpp *.cpp *.h *.c *.in *.cmake CMakeLists.txt *.py *.sh *.pml *.md *.j2)

# The files git tracks (what a clone holds); without git (a source archive),
# every such file on disk.
set(tracked "")
find_package(Git QUIET)
if(GIT_FOUND AND EXISTS ${SOURCE_DIR}/.git)
  execute_process(COMMAND ${GIT_EXECUTABLE} -C ${SOURCE_DIR} ls-files -- README.md CMakeLists.txt ${top_folders}
                  OUTPUT_VARIABLE tracked RESULT_VARIABLE git_status ERROR_QUIET)
  if(git_status EQUAL 0)
    string(REPLACE "\n" ";" tracked "${tracked}")
  else()
    set(tracked "")
  endif()
endif()
set(files "")
if(tracked)
  set(pattern_regex "(\\.(hpp|cpp|h|c|in|cmake|py|sh|pml|md|j2)|/CMakeLists\\.txt|^CMakeLists\\.txt|^\\.ci/run)$")
  foreach(file ${tracked})
    if(file MATCHES "${pattern_regex}" AND EXISTS ${SOURCE_DIR}/${file})
      list(APPEND files ${file})
    endif()
  endforeach()
else()
  set(files README.md CMakeLists.txt)
  foreach(folder ${top_folders})
    set(globs "")
    foreach(pattern ${patterns})
      list(APPEND globs ${SOURCE_DIR}/${folder}/${pattern})
    endforeach()
    file(GLOB_RECURSE found RELATIVE ${SOURCE_DIR} ${globs})
    list(APPEND files ${found})
  endforeach()
  if(EXISTS ${SOURCE_DIR}/.ci/run)
    list(APPEND files .ci/run)
  endif()
endif()

# Characters of a path, a glob or a placeholder (no space, quote, colon,
# semicolon, bracket or parenthesis: those end a citation in prose and code).
set(path_chars "A-Za-z0-9_.+<>*{},$/-")
# A path with a slash whose last part has an extension, and the character after it.
set(path_regex "[${path_chars}]*/[${path_chars}]*\\.[A-Za-z0-9]+[^A-Za-z0-9_]")
# A name ending in .md, and the character after it.
set(markdown_regex "[${path_chars}]*\\.md[^A-Za-z0-9_./-]")
# Pages lockstep writes, named in the text as outputs, not citations.
set(written_pages report.md)

# Sets ${result} to TRUE when `cited` (a path, glob or placeholder) names
# something relative to the root or to `base` (the citing file's folder).
function(citation_exists cited base result)
  string(REGEX REPLACE "<[^>]*>" "*" pattern "${cited}")
  string(REGEX REPLACE "{[^}]*}" "*" pattern "${pattern}")
  string(REGEX REPLACE "^(\\.\\.?/)+" "" from_root "${pattern}")
  foreach(candidate "${SOURCE_DIR}/${from_root}" "${SOURCE_DIR}/${base}/${pattern}")
    if(pattern MATCHES "[*?]")
      file(GLOB matches "${candidate}")
      if(matches)
        set(${result} TRUE PARENT_SCOPE)
        return()
      endif()
    elseif(EXISTS "${candidate}" OR EXISTS "${candidate}.in")
      set(${result} TRUE PARENT_SCOPE)
      return()
    endif()
  endforeach()
  set(${result} FALSE PARENT_SCOPE)
endfunction()

set(missing "")
set(checked 0)
foreach(file ${files})
  file(READ ${SOURCE_DIR}/${file} content)
  # Brackets and semicolons would split CMake's lists wrongly; a blank keeps
  # every offset (the line numbers below).
  string(REGEX REPLACE "[][;]" " " content "${content}")
  string(APPEND content "\n")
  get_filename_component(base ${file} DIRECTORY)
  set(citations "")
  string(REGEX MATCHALL "${path_regex}" paths "${content}")
  foreach(match ${paths})
    string(REGEX REPLACE ".$" "" cited "${match}")
    if(cited MATCHES "^/" OR cited MATCHES "\\$")
      continue()  # an absolute path, a URL's tail, or a CMake variable
    endif()
    string(REGEX REPLACE "^(\\.\\.?/)+" "" stripped "${cited}")
    string(REGEX MATCH "^[^/]+" first "${stripped}")
    if(NOT first IN_LIST top_folders AND NOT cited MATCHES "^\\.\\.?/"
       AND NOT (base AND IS_DIRECTORY ${SOURCE_DIR}/${base}/${first}))
      continue()  # not a path of this repository (build/, results/, a scratch file)
    endif()
    list(APPEND citations "${cited}")
  endforeach()
  string(REGEX MATCHALL "${markdown_regex}" pages "${content}")
  foreach(match ${pages})
    string(REGEX REPLACE ".$" "" cited "${match}")
    # A name (paths were checked above, globs are not pages), and not one of
    # the pages the tools write (`lockstep report` writes report.md).
    if(cited MATCHES "^[A-Za-z0-9_][A-Za-z0-9_.-]*$" AND NOT cited IN_LIST written_pages)
      list(APPEND citations "${cited}")
    endif()
  endforeach()
  list(REMOVE_DUPLICATES citations)
  list(LENGTH citations count)
  math(EXPR checked "${checked} + ${count}")
  foreach(cited ${citations})
    if(cited MATCHES "/")
      citation_exists("${cited}" "${base}" found)
    else()
      set(found FALSE)
      foreach(candidate "${SOURCE_DIR}/${base}/${cited}" "${SOURCE_DIR}/${cited}")
        if(EXISTS "${candidate}")
          set(found TRUE)
        endif()
      endforeach()
    endif()
    if(NOT found)
      # The line of its first occurrence.
      string(FIND "${content}" "${cited}" position)
      string(SUBSTRING "${content}" 0 ${position} before)
      string(REGEX MATCHALL "\n" newlines "${before}")
      list(LENGTH newlines line)
      math(EXPR line "${line} + 1")
      string(APPEND missing "  ${file}:${line} cites ${cited}, which does not exist\n")
    endif()
  endforeach()
endforeach()

if(missing)
  message(FATAL_ERROR "lockstep citations broken (cmake/check_citations.cmake):\n${missing}")
endif()
list(LENGTH files scanned)
file(WRITE ${STAMP} "citations ok: ${checked} distinct citations in ${scanned} files\n")
