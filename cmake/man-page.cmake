# Writes the man page of one command with help2man, from the command's --help and --version
# (CMakeLists.txt, "Man pages"; docs/cli.md, "Man pages"). Run as
#   cmake -DHELP2MAN=/usr/bin/help2man -DCOMMAND=build/bin/blmd-sim -DOUTPUT=man/blmd-sim.1
#         -P cmake/man-page.cmake
# The command is run by its name, from PATH, so that the page's usage line reads "blmd-sim"
# and not the build tree's path. NAME's one-line description is the --help's first line
# after "blmd-sim: ". The --help footer's "Exit status:" paragraph (apps/common/help.h),
# which help2man makes a subsection of OPTIONS, becomes the page's EXIT STATUS section; the
# example commands are set unfilled.
foreach(variable HELP2MAN COMMAND OUTPUT)
  if(NOT DEFINED ${variable})
    message(FATAL_ERROR "man-page.cmake: -D${variable}=... is required")
  endif()
endforeach()
get_filename_component(name "${COMMAND}" NAME)
get_filename_component(folder "${COMMAND}" DIRECTORY)

execute_process(COMMAND "${COMMAND}" --help OUTPUT_VARIABLE help RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "man-page.cmake: ${COMMAND} --help failed (${status})")
endif()
string(REGEX MATCH "^[^\n]*" first_line "${help}")
string(REGEX REPLACE "^${name}: *" "" description "${first_line}")

execute_process(
  COMMAND "${CMAKE_COMMAND}" -E env "PATH=${folder}:$ENV{PATH}" "${HELP2MAN}" --no-info
          --section=1 "--name=${description}" "--output=${OUTPUT}.tmp" "${name}"
  RESULT_VARIABLE status ERROR_VARIABLE errors)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "man-page.cmake: help2man ${name} failed (${status}): ${errors}")
endif()
file(READ "${OUTPUT}.tmp" page)
file(REMOVE "${OUTPUT}.tmp")
string(REPLACE ".SS \"Exit status:\"" ".SH \"EXIT STATUS\"" page "${page}")
# An example command ("$ " lines, which help2man sets in constant width) is kept as written,
# one line, rather than filled and justified to the page's width.
string(REGEX REPLACE "\n(\\\\f\\(CW\\$ [^\n]*)" "\n.nf\n\\1\n.fi" page "${page}")
if(NOT page MATCHES "\\.SH \"EXIT STATUS\"" OR NOT page MATCHES "\\.SH EXAMPLES")
  message(FATAL_ERROR "man-page.cmake: ${name}'s page has no EXIT STATUS or EXAMPLES section: "
                      "has the --help footer (apps/common/help.h) changed its layout?")
endif()
file(WRITE "${OUTPUT}" "${page}")
