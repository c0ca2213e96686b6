# SPDX-License-Identifier: MIT
# Installs the build into WORK_DIR/prefix, builds the embedding example (EXAMPLE_DIR) against
# it with find_package(defsim) (so it uses the installed defsim.hpp, defsim.h and libdefsim),
# and runs it.
include(${CMAKE_CURRENT_LIST_DIR}/../../../cmake/install_and_run.cmake)
set(prefix ${WORK_DIR}/prefix)
install_to(${prefix})
if(NOT EXISTS ${prefix}/include/defsim/defsim.hpp)
  message(FATAL_ERROR "defsim.hpp was not installed")
endif()
run(${CMAKE_COMMAND} -S ${EXAMPLE_DIR} -B ${WORK_DIR}/build -DCMAKE_PREFIX_PATH=${prefix}
    -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/defsim-embed 120)
message(STATUS "${out}")
