# e2e test image_folder_example: examples/image_folder_slam.cpp on a folder of PNG images (no rawlog). Renders a
# short room sequence with slam-synth, copies its CAMERA images into a folder of their own, writes the camera as an
# MRPT [CAMERA] block from <name>_synth.json, and runs the example with config/slam/synthetic.ini. Checks: exit code
# 0, one line per image, a summary line, a trajectory with a pose for most frames.
# Variables (-D): BIN_DIR, SOURCE_DIR, WORK_DIR; optional FRAMES (default 60).
if(NOT FRAMES)
  set(FRAMES 60)
endif()
include("${CMAKE_CURRENT_LIST_DIR}/../support/run_step.cmake")

file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}/images")
run("slam-synth" "${BIN_DIR}/slam-synth" --scenario room --frames ${FRAMES} --seed 1 --out "${WORK_DIR}/data" --quiet)
file(GLOB pngs "${WORK_DIR}/data/room_Images/CAMERA_*.png")
list(LENGTH pngs n_images)
if(NOT n_images EQUAL FRAMES)
  message(FATAL_ERROR "expected ${FRAMES} CAMERA images, found ${n_images}")
endif()
file(COPY ${pngs} DESTINATION "${WORK_DIR}/images")

file(READ "${WORK_DIR}/data/room_synth.json" info)
foreach(k width height fx fy cx cy)
  string(JSON ${k} GET "${info}" camera ${k})
endforeach()
file(WRITE "${WORK_DIR}/camera.ini" "[CAMERA]\nresolution = [${width} ${height}]\nfx = ${fx}\nfy = ${fy}\ncx = ${cx}\n"
                                    "cy = ${cy}\ndistortion_model = none\ndist = [0 0 0 0 0]\n")

run("image_folder_slam" "${BIN_DIR}/image_folder_slam" "${SOURCE_DIR}/config/slam/synthetic.ini"
    "${WORK_DIR}/camera.ini" "${WORK_DIR}/images" 15 "${WORK_DIR}/trajectory.txt")
string(REGEX MATCHALL "(^|\n)[0-9]+ [a-z]+[^\n]*" frame_lines "${RUN_OUTPUT}")
list(LENGTH frame_lines n)
if(NOT n EQUAL FRAMES)
  message(FATAL_ERROR "expected ${FRAMES} frame lines, got ${n}:\n${RUN_OUTPUT}")
endif()
if(NOT RUN_OUTPUT MATCHES "(^|\n)summary [^\n]+")
  message(FATAL_ERROR "no summary line:\n${RUN_OUTPUT}")
endif()
file(STRINGS "${WORK_DIR}/trajectory.txt" poses REGEX "^[0-9]")
list(LENGTH poses n_poses)
math(EXPR enough "${FRAMES} * 2 / 3")
if(n_poses LESS enough)
  message(FATAL_ERROR "only ${n_poses} of ${FRAMES} frames have a pose:\n${RUN_OUTPUT}")
endif()
message(STATUS "${n} frame lines, ${n_poses} poses")
file(REMOVE_RECURSE "${WORK_DIR}")
