# SPDX-License-Identifier: MIT
# The comparison of a picture with its golden, for the visual tests (visual_test.cmake) and the
# viewer's (tests/view/view_test.cmake). The tolerance (THRESHOLD, MAX_FRACTION) is documented in
# tests/render/README.md; PNGDIFF is the pngdiff program.
if(NOT DEFINED THRESHOLD)
  set(THRESHOLD 16)
endif()
if(NOT DEFINED MAX_FRACTION)
  set(MAX_FRACTION 0.0002)
endif()

# MODE update: copies IMAGE over GOLDEN. Otherwise compares them: EXPECT match (pngdiff exit 0)
# or differ (exit 1, proving the check can fail); DIFF receives pngdiff's picture of the pixels
# that differ.
function(defsim_golden_check image golden mode expect diff)
  if(NOT EXISTS "${image}")
    message(FATAL_ERROR "no ${image}")
  endif()
  if(mode STREQUAL "update")
    file(COPY_FILE "${image}" "${golden}")
    message(STATUS "updated ${golden}")
    return()
  endif()
  execute_process(COMMAND "${PNGDIFF}" "${image}" "${golden}" --threshold ${THRESHOLD}
                          --max-fraction ${MAX_FRACTION} --diff "${diff}" RESULT_VARIABLE rc)
  if(expect STREQUAL "match" AND NOT rc EQUAL 0)
    message(FATAL_ERROR "${image} does not match ${golden} (pngdiff exit ${rc}; see ${diff})")
  elseif(expect STREQUAL "differ" AND NOT rc EQUAL 1)
    message(FATAL_ERROR "${image} was expected to differ from ${golden} (pngdiff exit ${rc})")
  endif()
endfunction()
