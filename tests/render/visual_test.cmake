# SPDX-License-Identifier: MIT
# One visual test: render FRAME of SCENE and compare it with GOLDEN.
#   -DMODE=run      render while running (defsim-render SCENE.json)
#   -DMODE=frames   write VTK frames with `defsim run`, then render them with defsim-render
#   -DMODE=program  run PROGRAM IMAGE PROGRAM_ARGS... (a program drawing with the renderer
#                   library, e.g. render_colliders); DEFSIM, RENDER and SCENE are not used
#   -DMODE=update   render and copy the image over GOLDEN (regenerating goldens; with PROGRAM
#                   set, by the program)
#   -DEXPECT=match  the images must match within the tolerance (pngdiff exit 0)
#   -DEXPECT=differ the images must differ (pngdiff exit 1): proves the check can fail
#   -DSETS="world.gravity=[0,9.81,0];..."  scene overrides (defsim run --set)
# The tolerance (THRESHOLD, MAX_FRACTION) is documented in tests/render/README.md.
set(required PNGDIFF FRAME GOLDEN OUT MODE)
if(NOT DEFINED PROGRAM)
  list(APPEND required DEFSIM RENDER SCENE)
endif()
foreach(v ${required})
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "visual_test.cmake: ${v} is not set")
  endif()
endforeach()
if(NOT DEFINED EXPECT)
  set(EXPECT match)
endif()
include(${CMAKE_CURRENT_LIST_DIR}/golden_check.cmake)
file(REMOVE_RECURSE "${OUT}")
file(MAKE_DIRECTORY "${OUT}")
set(args)
foreach(s IN LISTS SETS)
  list(APPEND args --set "${s}")
endforeach()
string(LENGTH "00000${FRAME}" len)
math(EXPR start "${len} - 5")
string(SUBSTRING "00000${FRAME}" ${start} 5 padded)
set(image "${OUT}/frame_${padded}.png")
# One thread: the simulation is bit-identical for a fixed thread count.
if(DEFINED PROGRAM)
  execute_process(COMMAND "${PROGRAM}" "${image}" ${PROGRAM_ARGS} RESULT_VARIABLE rc)
elseif(MODE STREQUAL "frames")
  # Every frame: the renderer frames the camera and the colour scale over all of them, as
  # rendering while running does.
  execute_process(COMMAND "${DEFSIM}" run "${SCENE}" --threads 1 --progress none
                          --out "${OUT}" ${args} RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "defsim run failed (${rc})")
  endif()
  get_filename_component(name "${SCENE}" NAME_WE)
  execute_process(COMMAND "${RENDER}" "${OUT}/${name}.pvd" --scene "${SCENE}" --out "${OUT}"
                          --frames ${FRAME} RESULT_VARIABLE rc)
else()
  execute_process(COMMAND "${RENDER}" "${SCENE}" --frames ${FRAME} --threads 1 --progress none
                          --out "${OUT}" ${args} RESULT_VARIABLE rc)
endif()
if(NOT rc EQUAL 0 OR NOT EXISTS "${image}")
  message(FATAL_ERROR "rendering failed (${rc}); no ${image}")
endif()
defsim_golden_check("${image}" "${GOLDEN}" "${MODE}" "${EXPECT}" "${OUT}/diff.png")
