# SPDX-License-Identifier: MIT
# What `defsim run` writes into its output folder (issue 16), on the rope scene:
# - a reused --out is cleared of the earlier run's frames (a user's own file stays);
# - --no-vtk writes no VTK file at all; --vtk final writes only final.vtu;
# - the summary counts VTK and PNG frames;
# - with the renderer: PNG frames without VTK, no scratch file left, and defsim-render --out
#   creates its folder.
#   -DDEFSIM=defsim -DSCENE=rope.json -DOUT=dir -DHAVE_RENDER=ON|OFF [-DRENDER=defsim-render]
include(${CMAKE_CURRENT_LIST_DIR}/../../cmake/install_and_run.cmake)
file(REMOVE_RECURSE "${OUT}")
set(a "${OUT}/a")

macro(expect_files dir pattern want)
  file(GLOB got RELATIVE "${dir}" "${dir}/${pattern}")
  list(SORT got)
  if(NOT "${got}" STREQUAL "${want}")
    message(FATAL_ERROR "${dir}/${pattern}: got '${got}', want '${want}'")
  endif()
endmacro()
macro(expect_output regex)
  if(NOT out MATCHES "${regex}")
    message(FATAL_ERROR "output does not match '${regex}':\n${out}")
  endif()
endmacro()

# 0.09 s of frames of 0.03 s: frames 0 to 3.
run("${DEFSIM}" run "${SCENE}" --out "${a}" --progress lines --set world.duration=0.09)
expect_files("${a}" "frame_*.vtu" "frame_00000.vtu;frame_00001.vtu;frame_00002.vtu;frame_00003.vtu")
expect_output("4 VTK frames, 0 PNG frames, final.vtu")
file(WRITE "${a}/notes.txt" "the user's own file\n")
# A shorter run into the same folder: frames 2 and 3 of the first run are gone.
run("${DEFSIM}" run "${SCENE}" --out "${a}" --progress lines --set world.duration=0.03)
expect_files("${a}" "frame_*.vtu" "frame_00000.vtu;frame_00001.vtu")
expect_output("removed 6 files of an earlier run")
if(NOT EXISTS "${a}/notes.txt")
  message(FATAL_ERROR "clearing the output folder removed a file defsim did not write")
endif()
file(READ "${a}/rope.pvd" pvd)
if(pvd MATCHES "frame_00002")
  message(FATAL_ERROR "the .pvd still lists frame 2")
endif()

# With a collider (issue 28): each frame's colliders .vtu and .vtm, the scene's .pvd of the
# .vtm, the final state's three files; a reused folder is cleared of all of them (17 files),
# and a user's file that only looks like one stays.
set(ground "colliders=[{\"shape\": \"plane\", \"position\": [0, -5, 0]}]")
run("${DEFSIM}" run "${SCENE}" --out "${OUT}/f" --progress none --set world.duration=0.09
    --set "${ground}")
expect_files("${OUT}/f" "frame_*.vtm" "frame_00000.vtm;frame_00001.vtm;frame_00002.vtm;frame_00003.vtm")
expect_files("${OUT}/f" "*_colliders.vtu" "final_colliders.vtu;frame_00000_colliders.vtu;frame_00001_colliders.vtu;frame_00002_colliders.vtu;frame_00003_colliders.vtu")
expect_files("${OUT}/f" "*.pvd" "rope.pvd;rope_scene.pvd")
expect_files("${OUT}/f" "final.*" "final.vtm;final.vtu")
file(WRITE "${OUT}/f/frame_1a_colliders.vtu" "the user's own file\n")
run("${DEFSIM}" run "${SCENE}" --out "${OUT}/f" --progress lines --set world.duration=0.03
    --set "${ground}")
expect_output("removed 17 files of an earlier run")
expect_files("${OUT}/f" "frame_*.vtm" "frame_00000.vtm;frame_00001.vtm")
expect_files("${OUT}/f" "frame_1a_colliders.vtu" "frame_1a_colliders.vtu")

# --no-vtk: no .vtu and no .pvd at all; --vtk final: only final.vtu.
run("${DEFSIM}" run "${SCENE}" --out "${OUT}/b" --progress lines --set world.duration=0.06 --no-vtk)
expect_files("${OUT}/b" "*.vtu" "")
expect_files("${OUT}/b" "*.pvd" "")
expect_files("${OUT}/b" "energy.csv" "energy.csv")
expect_output("0 VTK frames, 0 PNG frames, energy.csv")
run("${DEFSIM}" run "${SCENE}" --out "${OUT}/c" --progress none --set world.duration=0.06 --vtk final)
expect_files("${OUT}/c" "*.vtu" "final.vtu")

if(HAVE_RENDER)
  run("${DEFSIM}" run "${SCENE}" --out "${OUT}/d" --progress lines --set world.duration=0.06
      --render --no-vtk)
  expect_files("${OUT}/d" "*.png" "contact_sheet.png;frame_00000.png;frame_00001.png;frame_00002.png")
  expect_files("${OUT}/d" "*.vtu" "")
  expect_output("0 VTK frames, 3 PNG frames, energy.csv")
  file(GLOB left "${OUT}/d/.*")
  if(left)
    message(FATAL_ERROR "scratch files left behind: ${left}")
  endif()
  # defsim-render creates its --out folder (and its parents).
  run("${RENDER}" "${a}/rope.pvd" --out "${OUT}/e/new/folder")
  expect_files("${OUT}/e/new/folder" "frame_*.png" "frame_00000.png;frame_00001.png")
endif()
