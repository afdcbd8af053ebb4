# CTest driver of the `external_consumer` e2e test (cmake -P). Installs the build tree into a temporary
# prefix, configures and builds tests/external_consumer (examples/minimal_slam.cpp) against it
# (find_package(priorslam CONFIG)), renders a short synthetic rawlog with the *installed* slam-synth and runs
# minimal_slam on it with the installed config/slam/synthetic.ini. Checks: exit code 0, one output line per
# frame, a `summary` line, the map file. Then runs the installed slam-run with the installed config from another
# folder (the config names the installed default vocabulary relative to itself): a trajectory and a map. Then, with
# the Python module, imports the installed package in a clean environment and runs it on the same frames.
#
# Variables (-D): BUILD_DIR, SOURCE_DIR, WORK_DIR; optional CONSUMER_SOURCE (examples/minimal_slam.cpp),
# FRAMES (40), GENERATOR, COMPILER_LAUNCHER, CXX_COMPILER, KEEP (keep WORK_DIR); PYTHON_EXECUTABLE,
# PYTHON_INSTALL_DIR and VERSION when the build has the Python module (step 6).
foreach(v BUILD_DIR SOURCE_DIR WORK_DIR)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "run_external_consumer.cmake: -D${v}=... is required")
  endif()
endforeach()
if(NOT DEFINED CONSUMER_SOURCE)
  set(CONSUMER_SOURCE "${SOURCE_DIR}/examples/minimal_slam.cpp")
endif()
if(NOT DEFINED FRAMES)
  set(FRAMES 40)
endif()

include("${CMAKE_CURRENT_LIST_DIR}/../support/run_step.cmake")

set(prefix "${WORK_DIR}/prefix")
set(build "${WORK_DIR}/consumer-build")
set(data "${WORK_DIR}/data")
file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${data}")

# 1. Install the build tree.
run("install into ${prefix}" ${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${prefix}")
foreach(f lib/cmake/priorslam/priorslamConfig.cmake lib/cmake/priorslam/priorslamConfigVersion.cmake
          lib/cmake/priorslam/priorslamTargets.cmake include/pslam/system/System.h include/pslam/datasets/Rawlog.h
          share/priorslam/config/slam/synthetic.ini bin/slam-synth bin/slam-run bin/slam-eval)
  if(NOT EXISTS "${prefix}/${f}")
    message(FATAL_ERROR "installed tree lacks ${f}")
  endif()
endforeach()
# App classes are not part of the package.
if(EXISTS "${prefix}/include/pslam/eval/EvalApp.h")
  message(FATAL_ERROR "an app class header was installed: include/pslam/eval/EvalApp.h")
endif()

# 2. Configure and build the consumer against the installed package only (the source tree is not searched).
set(cfg -S "${SOURCE_DIR}/tests/external_consumer" -B "${build}" -DCMAKE_BUILD_TYPE=Release
        "-DCMAKE_PREFIX_PATH=${prefix}" "-DCONSUMER_SOURCE=${CONSUMER_SOURCE}")
if(GENERATOR)
  list(APPEND cfg -G "${GENERATOR}")
endif()
if(COMPILER_LAUNCHER)
  list(APPEND cfg "-DCMAKE_CXX_COMPILER_LAUNCHER=${COMPILER_LAUNCHER}")
endif()
if(CXX_COMPILER)
  list(APPEND cfg "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}")
endif()
run("configure the consumer" ${CMAKE_COMMAND} ${cfg})
run("build the consumer" ${CMAKE_COMMAND} --build "${build}")
set(consumer "${build}/minimal_slam")

# 3. Render a short synthetic sequence with the installed tool.
run("slam-synth --scenario room --frames ${FRAMES}" "${prefix}/bin/slam-synth" --scenario room --frames ${FRAMES}
    --out "${data}" --quiet)
if(NOT EXISTS "${data}/room.rawlog")
  message(FATAL_ERROR "slam-synth wrote no ${data}/room.rawlog")
endif()

# 4. Run the consumer with the installed SLAM config.
set(map "${WORK_DIR}/map.slammap")
run("minimal_slam on ${FRAMES} frames" "${consumer}" "${prefix}/share/priorslam/config/slam/synthetic.ini"
    "${data}/room.rawlog" "${map}")
string(REGEX MATCHALL "(^|\n)[0-9]+ [^\n]*" frame_lines "${RUN_OUTPUT}")
list(LENGTH frame_lines n)
if(NOT n EQUAL FRAMES)
  message(FATAL_ERROR "expected ${FRAMES} frame lines, got ${n}:\n${RUN_OUTPUT}")
endif()
if(NOT RUN_OUTPUT MATCHES "(^|\n)summary [^\n]+")
  message(FATAL_ERROR "no summary line:\n${RUN_OUTPUT}")
endif()
string(REGEX MATCH "(^|\n)summary [^\n]+" summary "${RUN_OUTPUT}")
string(STRIP "${summary}" summary)
if(NOT EXISTS "${map}")
  message(FATAL_ERROR "the map file ${map} was not written")
endif()
file(SIZE "${map}" map_size)
message(STATUS "${n} frame lines, map ${map_size} bytes, ${summary}")

# 5. The installed slam-run with the installed config, started from a folder that is neither the source tree nor the
# prefix: the paths in the config (the default vocabulary, ../places/) are relative to the config file.
set(installed_config "${prefix}/share/priorslam/config/slam/synthetic.ini")
file(STRINGS "${installed_config}" vocabulary_line REGEX "^vocabulary *=")
if(vocabulary_line)
  string(REGEX REPLACE "^vocabulary *= *" "" vocabulary "${vocabulary_line}")
  if(NOT EXISTS "${prefix}/share/priorslam/config/slam/${vocabulary}")
    message(FATAL_ERROR "the installed config names ${vocabulary}, which was not installed")
  endif()
endif()
file(MAKE_DIRECTORY "${WORK_DIR}/elsewhere")
set(RUN_IN "${WORK_DIR}/elsewhere")
run("installed slam-run from another folder" "${prefix}/bin/slam-run" --config "${installed_config}"
    --rawlog "${data}/room.rawlog" --out run -q)
unset(RUN_IN)
foreach(f trajectory.txt map.slammap report.json)
  if(NOT EXISTS "${WORK_DIR}/elsewhere/run/${f}")
    message(FATAL_ERROR "the installed slam-run wrote no run/${f}")
  endif()
endforeach()

# 6. The installed Python package (when the build has it), from a clean environment: only PYTHONPATH names the
# prefix. It imports, tells its version, and its System on the installed config writes the trajectory the installed
# slam-run wrote above, byte for byte.
if(PYTHON_EXECUTABLE)
  set(site "${prefix}/${PYTHON_INSTALL_DIR}")
  file(GLOB module "${site}/priorslam/_core*.so")
  foreach(f __init__.py eval.py __init__.pyi eval.pyi py.typed)
    if(NOT EXISTS "${site}/priorslam/${f}")
      message(FATAL_ERROR "the installed Python package lacks ${f}")
    endif()
  endforeach()
  if(NOT module)
    message(FATAL_ERROR "no extension module in ${site}/priorslam")
  endif()
  set(RUN_IN "${WORK_DIR}/elsewhere")
  run("import the installed priorslam" /usr/bin/env -i "PYTHONPATH=${site}" "${PYTHON_EXECUTABLE}" -c
      "import priorslam\nprint(priorslam.__version__, priorslam.__file__)")  # no ';': run() forwards a list
  string(STRIP "${RUN_OUTPUT}" imported)
  if(NOT imported MATCHES "^${VERSION} ${site}/priorslam/__init__.py$")
    message(FATAL_ERROR "expected version ${VERSION} from ${site}, got: ${imported}")
  endif()
  string(CONCAT script "import priorslam, sys\n"
             "slam = priorslam.System(sys.argv[1])\n"
             "for f in priorslam.Rawlog(sys.argv[2], channels=slam.channels_used()):\n"
             "    slam.track_frame(f)\n"
             "slam.save_trajectory(sys.argv[3], comment='slam-run: every tracked frame, T_world_cam')\n")
  file(WRITE "${WORK_DIR}/run.py" "${script}")
  run("the installed priorslam on ${FRAMES} frames" /usr/bin/env -i "PYTHONPATH=${site}" "${PYTHON_EXECUTABLE}"
      "${WORK_DIR}/run.py" "${installed_config}" "${data}/room.rawlog" "${WORK_DIR}/python_trajectory.txt")
  unset(RUN_IN)
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files "${WORK_DIR}/python_trajectory.txt"
                  "${WORK_DIR}/elsewhere/run/trajectory.txt" RESULT_VARIABLE differ)
  if(differ)
    message(FATAL_ERROR "the installed Python package's trajectory differs from the installed slam-run's")
  endif()
  message(STATUS "installed Python package ${imported}: trajectory identical to slam-run's")
endif()

if(NOT KEEP)
  file(REMOVE_RECURSE "${WORK_DIR}")
endif()
