# SPDX-License-Identifier: MIT
# Shared by the install tests (tests/install, bindings/cpp/example), run with cmake -P:
# run(COMMAND...) stops the test on a non-zero exit and leaves its output in `out`;
# install_to(DIR) installs BUILD_DIR into a fresh DIR (WORK_DIR is emptied first).
macro(run)
  execute_process(COMMAND ${ARGV} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGV}\n${out}\n${err}")
  endif()
endmacro()

macro(install_to dir)
  file(REMOVE_RECURSE ${WORK_DIR})
  run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${dir})
endmacro()
