# SPDX-License-Identifier: MIT
# defsim run's steps per second (issue 28, point 9): the summary gives the simulation's rate
# (steps over the time in step, which its "time:" line prints) apart from the run's (steps over
# the wall time, rendering included), and each frame line the simulation's.
#   cmake -DDEFSIM=exe -DSCENE=rope.json -DOUT=dir [-DRENDER=ON] -P run_rates.cmake
set(args run ${SCENE} --progress lines --set world.duration=0.3 --out ${OUT})
if(RENDER)
  list(APPEND args --render)
endif()
execute_process(COMMAND ${DEFSIM} ${args} RESULT_VARIABLE rc OUTPUT_VARIABLE out
                ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "defsim run failed (${rc}): ${err}")
endif()
set(num "([0-9]+([.][0-9]+)?)")
set(re "done: [0-9]+ frames, ([0-9]+) steps [(]0 failed[)] in ${num} s wall: ${num} steps/s ")
string(APPEND re "simulating, ${num} steps/s with output and rendering")
if(NOT out MATCHES "${re}")
  message(FATAL_ERROR "no summary line with both rates:\n${out}")
endif()
set(steps ${CMAKE_MATCH_1})
set(wall ${CMAKE_MATCH_2})
set(sim_rate ${CMAKE_MATCH_4})
set(run_rate ${CMAKE_MATCH_6})
if(NOT out MATCHES "time: step ${num} s [^\n]*render ${num} s")
  message(FATAL_ERROR "no time line:\n${out}")
endif()
set(t_step ${CMAKE_MATCH_1})
set(t_render ${CMAKE_MATCH_3})
# The printed rates against steps / time. Times are printed in ms (three decimals) and rates
# rounded to whole steps/s, so rate x time_ms = 1000 steps within rate / 2 + time_ms / 2 + 1.
math(EXPR steps_x1000 "${steps} * 1000")
foreach(pair "sim_rate;t_step" "run_rate;wall")
  list(GET pair 0 rate_var)
  list(GET pair 1 time_var)
  set(rate ${${rate_var}})
  string(REPLACE "." "" time_ms "${${time_var}}")
  # the digits without leading zeros (REGEX REPLACE would apply "^0+" again after its first
  # match: "0502" became "52", a failure whenever the wall time read 0.50x s)
  string(REGEX MATCH "[1-9][0-9]*$|0$" time_ms "${time_ms}")
  math(EXPR diff "${rate} * ${time_ms} - ${steps_x1000}")
  if(diff LESS 0)
    math(EXPR diff "-(${diff})")
  endif()
  math(EXPR bound "${rate} / 2 + ${time_ms} / 2 + 1")
  if(diff GREATER bound)
    message(FATAL_ERROR
            "${rate_var} ${rate} x ${time_var} ${${time_var}} s is not ${steps} steps:\n${out}")
  endif()
endforeach()
if(RENDER AND NOT sim_rate GREATER run_rate)
  message(FATAL_ERROR "rendering counted in the simulation's rate (${sim_rate} <= ${run_rate}):"
                      "\n${out}")
endif()
# Frame lines: the simulation's rate, the same steps over time in step so far (not the wall's).
string(REGEX MATCH "frame +10/10 [^\n]* ([0-9]+) steps/s" last "${out}")
if(NOT last OR NOT CMAKE_MATCH_1 STREQUAL "${sim_rate}")
  message(FATAL_ERROR "the last frame line's rate is not the simulation's (${sim_rate}):\n${out}")
endif()
message(STATUS "${steps} steps: ${sim_rate} steps/s simulating (${t_step} s in step), "
               "${run_rate} steps/s in all (${wall} s wall, ${t_render} s rendering)")
