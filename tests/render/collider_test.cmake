# SPDX-License-Identifier: MIT
# The collider picture (render_colliders.c) against GOLDEN: it must match, and the same scene
# without colliders and markers must differ from it (proving that the overlay is drawn).
#   -DPROGRAM=render_colliders -DPNGDIFF=pngdiff -DGOLDEN=... -DOUT=dir [-DMODE=update]
file(REMOVE_RECURSE "${OUT}")
file(MAKE_DIRECTORY "${OUT}")
execute_process(COMMAND "${PROGRAM}" "${OUT}/colliders.png" RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "render_colliders failed (${rc})")
endif()
if(MODE STREQUAL "update")
  file(COPY_FILE "${OUT}/colliders.png" "${GOLDEN}")
  message(STATUS "updated ${GOLDEN}")
  return()
endif()
execute_process(COMMAND "${PNGDIFF}" "${OUT}/colliders.png" "${GOLDEN}" --threshold 16
                        --max-fraction 0.0002 --diff "${OUT}/diff.png" RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "colliders.png does not match ${GOLDEN} (see ${OUT}/diff.png)")
endif()
execute_process(COMMAND "${PROGRAM}" "${OUT}/bodies_only.png" --bodies-only RESULT_VARIABLE rc)
execute_process(COMMAND "${PNGDIFF}" "${OUT}/bodies_only.png" "${GOLDEN}" --threshold 16
                        --max-fraction 0.0002 RESULT_VARIABLE rc)
if(NOT rc EQUAL 1)
  message(FATAL_ERROR "the picture without colliders matches the golden (pngdiff exit ${rc})")
endif()
