# Installs the build tree into a scratch prefix, then configures, builds and runs tests/consumer against it.
# Usage: cmake -DBUILD_DIR=<volcl build> -DSOURCE_DIR=<tests/consumer> -DWORK_DIR=<scratch> -P run.cmake
file(REMOVE_RECURSE ${WORK_DIR})
foreach(_step
    "${CMAKE_COMMAND};--install;${BUILD_DIR};--prefix;${WORK_DIR}/prefix"
    "${CMAKE_COMMAND};-S;${SOURCE_DIR};-B;${WORK_DIR}/build;-DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix"
    "${CMAKE_COMMAND};--build;${WORK_DIR}/build"
    "${WORK_DIR}/build/consumer")
  execute_process(COMMAND ${_step} RESULT_VARIABLE _rc OUTPUT_VARIABLE _out ERROR_VARIABLE _err)
  if(NOT _rc EQUAL 0)
    message(FATAL_ERROR "consumer step failed (${_rc}): ${_step}\n${_out}\n${_err}")
  endif()
endforeach()
message(STATUS "${_out}")
