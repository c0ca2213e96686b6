# SPDX-License-Identifier: MIT
# Creates a fresh virtual environment (without system site packages) in WORK_DIR, installs the
# package with `pip install PACKAGE_DIR` (scikit-build-core builds and bundles libdefsim), and
# runs smoke_installed.py from WORK_DIR with none of the variables that point the package at a
# build tree, so that it must use what pip installed.
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
macro(run)
  execute_process(COMMAND ${ARGV} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err
                  WORKING_DIRECTORY ${WORK_DIR})
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGV}\n${out}\n${err}")
  endif()
endmacro()
foreach(var DEFSIM_LIBRARY DEFSIM_BACKEND_PATH PYTHONPATH PYTHONHOME
            PIP_REQUIRE_VIRTUALENV VIRTUAL_ENV)
  unset(ENV{${var}})
endforeach()
string(TIMESTAMP t0 "%s")
run(${PYTHON} -m venv ${WORK_DIR}/venv)
set(py ${WORK_DIR}/venv/bin/python)
run(${py} -m pip install --disable-pip-version-check -q ${PACKAGE_DIR})
string(TIMESTAMP t1 "%s")
run(${py} ${PACKAGE_DIR}/tests/smoke_installed.py)
string(TIMESTAMP t2 "%s")
math(EXPR install_s "${t1} - ${t0}")
math(EXPR smoke_s "${t2} - ${t1}")
message(STATUS "${out}")
message(STATUS "venv + pip install: ${install_s} s, smoke: ${smoke_s} s")
