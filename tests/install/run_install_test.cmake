# SPDX-License-Identifier: MIT
# Installs the build into WORK_DIR/prefix, then builds consumers against it with
# find_package(defsim) (CMake package: defsim::defsim, defsim::defsim_static,
# defsim::defsim_scene and defsim::defsim_render) and with pkg-config (defsim, defsim_scene,
# defsim_render), and runs them. The static consumer finds every module backend through the
# module directory the install recorded in libdefsim.a. With no
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
# The message says how to point the library at other modules.
if(NOT out MATCHES "DEFSIM_BACKEND_PATH")
  message(FATAL_ERROR "the unknown-backend message does not name DEFSIM_BACKEND_PATH: ${out}")
endif()

# Linked with the static library (issue 28, point 3): the executable is its own "library", so
# the modules come from the module directory that the install recorded in libdefsim.a (the
# prefix's <libdir>/defsim, though `cmake --install --prefix` chose the prefix after configure).
run(${WORK_DIR}/consumer/consumer_static ${BACKENDS})
message(STATUS "every backend from a static consumer:\n${out}")
run(${WORK_DIR}/consumer/consumer_static --unknown no_such_backend)
if(NOT out MATCHES "DEFSIM_BACKEND_PATH" OR NOT out MATCHES "${prefix}/lib[^ ]*/defsim")
  message(FATAL_ERROR "static consumer: the message names neither DEFSIM_BACKEND_PATH nor the "
                      "prefix's module directory: ${out}")
endif()

# libdefsim_scene and libdefsim_render (issue 28, point 8): versioned SONAMEs like libdefsim's,
# targets of the package (scene_consumer above) and .pc files (below).
get_filename_component(scenes ${SOURCE_DIR}/../scenes ABSOLUTE)
set(extra_libs scene)
if(EXISTS ${prefix}/include/defsim/render.h)
  list(APPEND extra_libs render)
endif()
foreach(lib defsim ${extra_libs})
  if(NOT lib STREQUAL "defsim")
    set(lib defsim_${lib})
  endif()
  file(GLOB real ${prefix}/lib*/lib${lib}.so.*.*.*)
  if(NOT real)
    message(FATAL_ERROR "no versioned lib${lib}.so.X.Y.Z installed")
  endif()
  run(readelf -d ${real})
  if(NOT out MATCHES "SONAME[^[]*\\[lib${lib}[.]so[.][0-9]+\\]")
    message(FATAL_ERROR "${real}: no versioned SONAME lib${lib}.so.<major>:\n${out}")
  endif()
endforeach()
set(png ${WORK_DIR}/scene_consumer.png)
run(${WORK_DIR}/consumer/scene_consumer ${scenes}/rope.json ${png})
message(STATUS "find_package scene consumer: ${out}")
if("render" IN_LIST extra_libs AND NOT EXISTS ${png})
  message(FATAL_ERROR "the scene consumer rendered no ${png}")
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
# The scene and render libraries through their .pc files (which require defsim's).
set(pc_libs defsim_scene)
set(pc_defs "")
if("render" IN_LIST extra_libs)
  list(APPEND pc_libs defsim_render)
  set(pc_defs -DDEFSIM_HAVE_RENDER)
endif()
run(pkg-config --cflags --libs ${pc_libs})
string(STRIP "${out}" flags)
separate_arguments(flags UNIX_COMMAND "${flags}")
run(cc -std=c11 ${pc_defs} ${SOURCE_DIR}/scene_consumer.c -o ${WORK_DIR}/pc_scene_consumer
    ${flags} -lm)
file(REMOVE ${png})
run(${WORK_DIR}/pc_scene_consumer ${scenes}/rope.json ${png})
message(STATUS "pkg-config scene consumer (${pc_libs}): ${out}")
if("render" IN_LIST extra_libs AND NOT EXISTS ${png})
  message(FATAL_ERROR "the pkg-config scene consumer rendered no ${png}")
endif()
# Every installed program answers --version with the library's version.
file(GLOB programs ${prefix}/bin/*)
foreach(p ${programs})
  run(${p} --version)
  if(NOT out MATCHES "[(]defsim [0-9]+[.][0-9]+[.][0-9]+[)]")
    message(FATAL_ERROR "${p} --version: ${out}")
  endif()
endforeach()
