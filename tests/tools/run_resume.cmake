# SPDX-License-Identifier: MIT
# defsim run --checkpoint-every / --resume (issue 17): a run stopped at a checkpoint and resumed
# writes the same bytes as the run that was never stopped (frames, .pvd, energy.csv, final.vtu).
# -DCLI=defsim binary -DSCENE=scene.json -DBACKEND=name -DOUT=scratch folder
set(common ${SCENE} --progress none --backend ${BACKEND})
file(REMOVE_RECURSE ${OUT})
function(run_cli)
  execute_process(COMMAND ${CLI} run ${common} ${ARGN} RESULT_VARIABLE rc ERROR_VARIABLE err
                  OUTPUT_QUIET)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "defsim run ${ARGN} failed (${rc}): ${err}")
  endif()
endfunction()
# The whole run; a run of half the duration with checkpoints every 2 frames (the last at frame
# 4 of 5), resumed with the whole duration.
run_cli(--set world.duration=0.3 --out ${OUT}/whole)
run_cli(--set world.duration=0.15 --checkpoint-every 2 --out ${OUT}/parts)
if(NOT EXISTS ${OUT}/parts/checkpoint.dfck)
  message(FATAL_ERROR "no checkpoint written")
endif()
run_cli(--set world.duration=0.3 --resume ${OUT}/parts)
file(GLOB frames RELATIVE ${OUT}/whole ${OUT}/whole/*.vtu ${OUT}/whole/*.pvd)
list(LENGTH frames n)
if(n LESS 10)
  message(FATAL_ERROR "expected at least 10 VTK files, got ${n}")
endif()
foreach(f energy.csv ${frames})
  file(SHA256 ${OUT}/whole/${f} a)
  file(SHA256 ${OUT}/parts/${f} b)
  if(NOT a STREQUAL b)
    message(FATAL_ERROR "${f} differs between the whole run and the resumed one")
  endif()
endforeach()
# A checkpoint of another scene is refused.
execute_process(COMMAND ${CLI} run ${common} --set world.duration=0.3 --set
                bodies.0.mesh.cells=[6,2,2] --resume ${OUT}/parts
                RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_QUIET)
if(rc EQUAL 0 OR NOT err MATCHES "resume")
  message(FATAL_ERROR "a checkpoint of another scene was not refused (${rc}): ${err}")
endif()
message(STATUS "${n} VTK files and energy.csv identical after resuming")
