# Helper functions shared by every library and app.
#
# priorslam_add_library(<name> SOURCES ... [DEPS ...])
#   creates target priorslam_<name> (alias priorslam::<name>) from libs/<name>/src,
#   public include dir libs/<name>/include.
# priorslam_add_test(<name> SOURCES ... [DEPS ...] [LABELS unit|data|e2e])
#   creates a GoogleTest executable registered with CTest (one CTest entry per executable).
# priorslam_add_app(<exe-name> SOURCES ... [DEPS ...])

function(priorslam_add_library name)
  cmake_parse_arguments(A "" "" "SOURCES;DEPS" ${ARGN})
  add_library(priorslam_${name} ${A_SOURCES})
  add_library(priorslam::${name} ALIAS priorslam_${name})
  target_include_directories(priorslam_${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  target_compile_options(priorslam_${name} PRIVATE ${PRIORSLAM_WARNINGS})
  target_link_libraries(priorslam_${name} PUBLIC ${A_DEPS})
endfunction()

function(priorslam_add_test name)
  if(NOT PRIORSLAM_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(A "" "" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${A_SOURCES})
  target_compile_options(${name} PRIVATE ${PRIORSLAM_WARNINGS})
  target_link_libraries(${name} PRIVATE ${A_DEPS} GTest::gtest GTest::gtest_main)
  target_compile_definitions(${name} PRIVATE
    PRIORSLAM_SHARED_DATA_DIR="${PRIORSLAM_SHARED_DATA_DIR}"
    PRIORSLAM_SOURCE_DIR="${CMAKE_SOURCE_DIR}"
    PRIORSLAM_BINARY_DIR="${CMAKE_BINARY_DIR}")
  if(NOT A_LABELS)
    set(A_LABELS unit)
  endif()
  add_test(NAME ${name} COMMAND ${name} WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
  set_tests_properties(${name} PROPERTIES LABELS "${A_LABELS}" SKIP_RETURN_CODE 77 TIMEOUT 900)
endfunction()

function(priorslam_add_app name)
  cmake_parse_arguments(A "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${A_SOURCES})
  target_compile_options(${name} PRIVATE ${PRIORSLAM_WARNINGS})
  target_link_libraries(${name} PRIVATE ${A_DEPS})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bin)
endfunction()
