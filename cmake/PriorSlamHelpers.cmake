# Helper functions shared by every library and app.
#
# priorslam_add_library(<name> SOURCES ... [DEPS ...])
#   creates target priorslam_<name> (alias priorslam::<name>) from libs/<name>/src, public include dir
#   libs/<name>/include (include/ once installed). The library, its headers and its entry in the CMake
#   package (export set priorslamTargets, imported as priorslam::<name>) are installed: every algorithm
#   library goes through this function, so each is exported exactly once.
# priorslam_add_app_library(<name> SOURCES ... [DEPS ...])
#   the app class of one tool (arguments, files, reports, plots): target priorslam_<name>_app
#   (alias priorslam::<name>_app), public include dir apps/<tool>/include. Built for the tool and its
#   tests only: neither installed nor exported, and no algorithm library may link it.
# priorslam_add_test(<name> SOURCES ... [DEPS ...] [LABELS unit|data|e2e] [COST seconds])
#   creates a GoogleTest executable registered with CTest (one CTest entry per executable). Test sources are
#   compiled with ${PRIORSLAM_TEST_OPTIMIZATION} after the build type's flags (-O1 in Release: the code under
#   test is the libraries', compiled with the build type's own flags). COST: the test's run time in seconds on
#   the 2-core machine, given for the long ones. CTest starts the costliest tests first, so that under
#   ctest -j2 on a fresh build (no timing history yet) a long e2e test does not start last and run alone.
# priorslam_add_app(<exe-name> SOURCES ... [DEPS ...])
#   an executable in <build>/bin. Executables of apps/<tool>/ are the tools: installed into bin/.
#   Executables elsewhere (libs/*/bench) are developer benchmarks and are not installed.
# priorslam_install_package()
#   called once at the end of the top-level CMakeLists.txt: the interface target priorslam::priorslam
#   (links every exported library), the export file, priorslamConfig.cmake and its version file.
include(GNUInstallDirs)

set(PRIORSLAM_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/priorslam" CACHE STRING
    "Where the CMake package files are installed (relative to the prefix)")
set(PRIORSLAM_INSTALL_DATADIR "${CMAKE_INSTALL_DATADIR}/priorslam" CACHE STRING
    "Where config/ is installed (relative to the prefix)")

function(priorslam_add_library name)
  cmake_parse_arguments(A "" "" "SOURCES;DEPS" ${ARGN})
  add_library(priorslam_${name} ${A_SOURCES})
  add_library(priorslam::${name} ALIAS priorslam_${name})
  set_target_properties(priorslam_${name} PROPERTIES EXPORT_NAME ${name})
  target_include_directories(priorslam_${name} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_compile_options(priorslam_${name} PRIVATE ${PRIORSLAM_WARNINGS})
  target_link_libraries(priorslam_${name} PUBLIC ${A_DEPS})
  install(TARGETS priorslam_${name} EXPORT priorslamTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  if(EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/include)
    install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  endif()
  set_property(GLOBAL APPEND PROPERTY PRIORSLAM_EXPORTED_LIBRARIES priorslam_${name})
endfunction()

function(priorslam_add_app_library name)
  cmake_parse_arguments(A "" "" "SOURCES;DEPS" ${ARGN})
  add_library(priorslam_${name}_app STATIC ${A_SOURCES})
  add_library(priorslam::${name}_app ALIAS priorslam_${name}_app)
  target_include_directories(priorslam_${name}_app PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  target_compile_options(priorslam_${name}_app PRIVATE ${PRIORSLAM_WARNINGS})
  target_link_libraries(priorslam_${name}_app PUBLIC ${A_DEPS})
endfunction()

function(priorslam_add_test name)
  if(NOT PRIORSLAM_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(A "" "COST" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${A_SOURCES})
  target_compile_options(${name} PRIVATE ${PRIORSLAM_WARNINGS} ${PRIORSLAM_TEST_OPTIMIZATION})
  target_link_libraries(${name} PRIVATE ${A_DEPS} GTest::gtest GTest::gtest_main)
  target_include_directories(${name} PRIVATE ${CMAKE_SOURCE_DIR}/tests/support)  # pslam_test/TestSupport.h
  target_compile_definitions(${name} PRIVATE
    PRIORSLAM_SHARED_DATA_DIR="${PRIORSLAM_SHARED_DATA_DIR}"
    PRIORSLAM_SOURCE_DIR="${CMAKE_SOURCE_DIR}"
    PRIORSLAM_BINARY_DIR="${CMAKE_BINARY_DIR}")
  if(NOT A_LABELS)
    set(A_LABELS unit)
  endif()
  add_test(NAME ${name} COMMAND ${name} WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
  set_tests_properties(${name} PROPERTIES LABELS "${A_LABELS}" SKIP_RETURN_CODE 77 TIMEOUT 900)
  if(A_COST)
    set_tests_properties(${name} PROPERTIES COST ${A_COST})
  endif()
endfunction()

function(priorslam_add_app name)
  cmake_parse_arguments(A "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${A_SOURCES})
  target_compile_options(${name} PRIVATE ${PRIORSLAM_WARNINGS})
  target_link_libraries(${name} PRIVATE ${A_DEPS})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bin)
  file(RELATIVE_PATH _rel "${PROJECT_SOURCE_DIR}/apps" "${CMAKE_CURRENT_SOURCE_DIR}")
  if(NOT _rel MATCHES "^\\.\\.")
    install(TARGETS ${name} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  endif()
endfunction()

function(priorslam_install_package)
  include(CMakePackageConfigHelpers)
  get_property(_libs GLOBAL PROPERTY PRIORSLAM_EXPORTED_LIBRARIES)
  # priorslam::priorslam: one target that brings every library (and, through them, their dependencies).
  add_library(priorslam_all INTERFACE)
  add_library(priorslam::priorslam ALIAS priorslam_all)
  set_target_properties(priorslam_all PROPERTIES EXPORT_NAME priorslam)
  target_link_libraries(priorslam_all INTERFACE ${_libs})
  install(TARGETS priorslam_all EXPORT priorslamTargets)
  install(EXPORT priorslamTargets NAMESPACE priorslam:: FILE priorslamTargets.cmake
    DESTINATION ${PRIORSLAM_INSTALL_CMAKEDIR})
  string(REPLACE "priorslam_" "" PRIORSLAM_PACKAGE_LIBRARIES "${_libs}")
  string(REPLACE ";" " " PRIORSLAM_PACKAGE_LIBRARIES "${PRIORSLAM_PACKAGE_LIBRARIES}")
  string(REPLACE ";" " " PRIORSLAM_MRPT_MODULES "${PRIORSLAM_MRPT_MODULES}")
  string(REPLACE ";" " " PRIORSLAM_OPENCV_COMPONENTS "${PRIORSLAM_OPENCV_COMPONENTS}")
  configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/priorslamConfig.cmake.in
    ${PROJECT_BINARY_DIR}/cmake/priorslamConfig.cmake
    INSTALL_DESTINATION ${PRIORSLAM_INSTALL_CMAKEDIR}
    PATH_VARS PRIORSLAM_INSTALL_DATADIR)
  write_basic_package_version_file(${PROJECT_BINARY_DIR}/cmake/priorslamConfigVersion.cmake
    VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
  install(FILES ${PROJECT_BINARY_DIR}/cmake/priorslamConfig.cmake
                ${PROJECT_BINARY_DIR}/cmake/priorslamConfigVersion.cmake
    DESTINATION ${PRIORSLAM_INSTALL_CMAKEDIR})
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/config/ DESTINATION ${PRIORSLAM_INSTALL_DATADIR}/config)
endfunction()
