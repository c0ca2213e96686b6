# SPDX-License-Identifier: MIT
# One viewer test (tests/view/README.md): `defsim view SCENE --script SCRIPT` under Xvfb in OUT
# (the script's screenshots are written there), then each screenshot against its golden.
#   -DDEFSIM, -DPNGDIFF, -DSCENE, -DSCRIPT, -DOUT, -DGOLDEN_DIR: what and where
#   -DSHOTS=a,b       screenshots (a.png ...) compared with GOLDEN_DIR/a.png ...
#   -DXVFB_RUN=path   run under xvfb-run (else on the display of DISPLAY)
#   -DMODE=run        the script's expectations must hold and the screenshots match
#   -DMODE=fail       the script must fail (exit 1: an expectation failed) and every screenshot
#                     differ from its golden: proves the checks can fail
#   -DMODE=update     run and copy the screenshots over their goldens
#   -DARGS=--paused,...  more options for defsim view (comma-separated)
# The tolerance is that of the visual tests (tests/render/README.md).
foreach(v DEFSIM PNGDIFF SCENE SCRIPT OUT GOLDEN_DIR MODE)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "view_test.cmake: ${v} is not set")
  endif()
endforeach()
include(${CMAKE_CURRENT_LIST_DIR}/../render/golden_check.cmake)
string(REPLACE "," ";" SHOTS "${SHOTS}")
string(REPLACE "," ";" ARGS "${ARGS}")
file(REMOVE_RECURSE "${OUT}")
file(MAKE_DIRECTORY "${OUT}")
set(cmd "${DEFSIM}" view "${SCENE}" --script "${SCRIPT}" --threads 1 --no-timing ${ARGS})
if(XVFB_RUN)
  set(cmd "${XVFB_RUN}" -a -s "-screen 0 1280x1024x24" ${cmd})
endif()
execute_process(COMMAND ${cmd} WORKING_DIRECTORY "${OUT}" RESULT_VARIABLE rc)
if(MODE STREQUAL "fail")
  if(NOT rc EQUAL 1)
    message(FATAL_ERROR "defsim view was expected to fail an expectation (exit 1), got ${rc}")
  endif()
elseif(NOT rc EQUAL 0)
  message(FATAL_ERROR "defsim view failed (${rc})")
endif()
set(expect match)
if(MODE STREQUAL "fail")
  set(expect differ)
endif()
foreach(shot IN LISTS SHOTS)
  defsim_golden_check("${OUT}/${shot}.png" "${GOLDEN_DIR}/${shot}.png" "${MODE}" "${expect}"
                      "${OUT}/${shot}_diff.png")
endforeach()
