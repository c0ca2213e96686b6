# SPDX-License-Identifier: MIT
# Installs the build into WORK_DIR/prefix, then builds two consumers against it: one with
# find_package(defsim) (CMake package) and one with pkg-config, and runs both. With no
# DEFSIM_BACKEND_PATH or LD_LIBRARY_PATH set, the first creates and steps a world with every
# backend BACKENDS lists (built in or modules: libdefsim finds <libdir>/defsim by itself), the
# installed `defsim run` runs a scene with a module backend, the installed programs carry a
# relative RUNPATH ($ORIGIN/../lib) and nothing points into the build tree, and the tree still
# runs after being moved elsewhere.
cmake_policy(SET CMP0057 NEW)
include(${CMAKE_CURRENT_LIST_DIR}/../../cmake/install_and_run.cmake)
string(REPLACE "," ";" BACKENDS "${BACKENDS}")
unset(ENV{DEFSIM_BACKEND_PATH})
unset(ENV{LD_LIBRARY_PATH})
set(prefix ${WORK_DIR}/prefix)
install_to(${prefix})
run(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/consumer -DCMAKE_PREFIX_PATH=${prefix})
run(${CMAKE_COMMAND} --build ${WORK_DIR}/consumer)
run(${WORK_DIR}/consumer/consumer)
message(STATUS "find_package consumer: ${out}")
run(${WORK_DIR}/consumer/consumer ${BACKENDS})
message(STATUS "every backend from the installed tree:\n${out}")
# A misspelt module name is refused (status checked by the consumer) and the nearest is named.
run(${WORK_DIR}/consumer/consumer --unknown newton_cholmd)
if(newton_cholmod IN_LIST BACKENDS AND NOT out MATCHES "'newton_cholmod'")
  message(FATAL_ERROR "no suggestion for newton_cholmd: ${out}")
endif()

# RUNPATH of every installed ELF file: programs find libdefsim relative to themselves, and
# nothing (programs, library, modules) names the build tree.
file(GLOB_RECURSE installed ${prefix}/bin/* ${prefix}/lib*/*.so*)
foreach(f ${installed})
  if(IS_SYMLINK ${f})
    continue()
  endif()
  run(readelf -d ${f})
  string(REGEX MATCH "(RUNPATH|RPATH)[^[]*\\[([^]]*)\\]" m "${out}")
  set(rpath "${CMAKE_MATCH_2}")
  string(FIND "${rpath}" "${BUILD_DIR}" at)
  if(NOT at EQUAL -1)
    message(FATAL_ERROR "${f}: RUNPATH ${rpath} names the build tree")
  endif()
  if(f MATCHES "/bin/[^/]+$" AND NOT rpath MATCHES "\\$ORIGIN/\\.\\./lib")
    message(FATAL_ERROR "${f}: RUNPATH '${rpath}' lacks $ORIGIN/../lib")
  endif()
endforeach()

# The installed tool, a module backend, then the same tree moved elsewhere.
set(backend symplectic_euler)
if(newton_cholmod IN_LIST BACKENDS)
  set(backend newton_cholmod)
endif()
get_filename_component(scenes ${SOURCE_DIR}/../scenes ABSOLUTE)
foreach(root ${prefix} ${WORK_DIR}/moved)
  if(root STREQUAL "${WORK_DIR}/moved")
    file(RENAME ${prefix} ${root})
  endif()
  run(${root}/bin/defsim run ${scenes}/cantilever.json --backend ${backend} --progress none
      --set world.duration=0.02 --out ${WORK_DIR}/run_out)
  if(NOT EXISTS ${WORK_DIR}/run_out/final.vtu)
    message(FATAL_ERROR "${root}/bin/defsim run wrote no final.vtu")
  endif()
  message(STATUS "${root}/bin/defsim run --backend ${backend}: ok")
endforeach()
file(RENAME ${WORK_DIR}/moved ${prefix})

file(GLOB pcdir LIST_DIRECTORIES true ${prefix}/lib*/pkgconfig ${prefix}/lib/*/pkgconfig)
set(ENV{PKG_CONFIG_PATH} "${pcdir}")
run(pkg-config --cflags --libs defsim)
string(STRIP "${out}" flags)
separate_arguments(flags UNIX_COMMAND "${flags}")
run(cc -std=c11 ${SOURCE_DIR}/consumer.c -o ${WORK_DIR}/pc_consumer ${flags} -Wl,-rpath,${prefix}/lib)
file(GLOB libdirs LIST_DIRECTORIES true ${prefix}/lib ${prefix}/lib/*)
string(REPLACE ";" ":" ldpath "${libdirs}")
set(ENV{LD_LIBRARY_PATH} "${ldpath}")
run(${WORK_DIR}/pc_consumer)
message(STATUS "pkg-config consumer: ${out}")
