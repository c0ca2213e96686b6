# SPDX-License-Identifier: MIT
# One tool's command line (issue 28, point 6): -h and --help print the usage on stdout and exit 0,
# --version prints the library's version and exits 0, an unknown option and a missing value are
# usage errors (a message on stderr, exit status 2), and none of these runs anything: each
# returns within seconds and the working directory stays empty.
#   cmake -DTOOL=exe [-DSUB=command] [-DVALUE_OPT=--out] -DVERSION=x.y.z -DWORK=dir
#         -P check_cli.cmake
# SUB: arguments before the option under test (a command's name, "defsim-render"'s scene).
foreach(v TOOL VERSION WORK)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "check_cli.cmake: ${v} not set")
  endif()
endforeach()
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")
set(pre ${SUB})
get_filename_component(name "${TOOL}" NAME)
set(failures "")

function(call)
  execute_process(COMMAND "${TOOL}" ${pre} ${ARGN} WORKING_DIRECTORY "${WORK}" TIMEOUT 20
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  set(rc "${rc}" PARENT_SCOPE)
  set(out "${out}" PARENT_SCOPE)
  set(err "${err}" PARENT_SCOPE)
endfunction()

# expect(WHAT RC OUT_REGEX ERR_REGEX): the last call's exit status is RC, its stdout matches
# OUT_REGEX and its stderr ERR_REGEX ("^$": empty).
macro(expect what want_rc out_re err_re)
  if(NOT rc STREQUAL "${want_rc}" OR NOT out MATCHES "${out_re}" OR NOT err MATCHES "${err_re}")
    list(APPEND failures
         "${name} ${pre} ${what}: exit ${rc} (want ${want_rc}), stdout [${out}], stderr [${err}]")
  endif()
endmacro()

foreach(flag -h --help)
  call(${flag})
  expect("${flag}" 0 "^usage: " "^$")
endforeach()
call(--version)
string(REPLACE "." "[.]" version_re "${VERSION}")
expect("--version" 0 "[(]defsim ${version_re}[)]\n$" "^$")
call(--no-such-option)
expect("--no-such-option" 2 "^$" "unknown option --no-such-option")
call(-Z)
expect("-Z" 2 "^$" "unknown option -Z")
call(--help=yes)
expect("--help=yes" 2 "^$" "option --help takes no value")
if(DEFINED VALUE_OPT AND NOT VALUE_OPT STREQUAL "")
  call(${VALUE_OPT})
  expect("${VALUE_OPT} (no value)" 2 "^$" "option ${VALUE_OPT} needs a value")
  # Help wins wherever it stands, before anything runs.
  call(${VALUE_OPT} 8 --help)
  expect("${VALUE_OPT} 8 --help" 0 "^usage: " "^$")
endif()

file(GLOB left RELATIVE "${WORK}" "${WORK}/*")
if(left)
  list(APPEND failures "${name} ${pre}: the calls wrote into the working directory: ${left}")
endif()
if(failures)
  list(JOIN failures "\n" msg)
  message(FATAL_ERROR "${msg}")
endif()
message(STATUS "${name} ${pre}: -h, --help, --version, bad options and missing values as expected")
