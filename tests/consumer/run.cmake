# Installs the build tree into a scratch prefix, checks what was installed, then builds tests/consumer against
# the prefix alone and runs it and the installed `volcl`.
# Usage: cmake -DBUILD_DIR=<volcl build> -DSOURCE_DIR=<tests/consumer> -DPROJECT_DIR=<volcl source>
#              -DWORK_DIR=<scratch> -DVERSION=<volcl version> -P run.cmake
cmake_minimum_required(VERSION 3.25) # IN_LIST, env --unset
file(REMOVE_RECURSE ${WORK_DIR})
set(PREFIX ${WORK_DIR}/prefix)

# Runs one command with no LD_LIBRARY_PATH (installed binaries must find their libraries by RUNPATH).
function(step)
  execute_process(COMMAND ${CMAKE_COMMAND} -E env --unset=LD_LIBRARY_PATH ${ARGN}
                  RESULT_VARIABLE _rc OUTPUT_VARIABLE _out ERROR_VARIABLE _err)
  if(NOT _rc EQUAL 0)
    message(FATAL_ERROR "consumer step failed (${_rc}): ${ARGN}\n${_out}\n${_err}")
  endif()
  set(STEP_OUTPUT "${_out}${_err}" PARENT_SCOPE)
endfunction()

step(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${PREFIX})

# The installed headers are exactly the public list: an internal header (IoDetail.hpp, XmlDocument.hpp, the
# entropy coders, the viewer's, the CLI's) installed, or a listed one missing, fails here.
file(STRINGS ${BUILD_DIR}/volcl-public-headers.txt _expected)
file(GLOB_RECURSE _installed RELATIVE ${PREFIX}/include/volcl ${PREFIX}/include/*)
list(SORT _installed)
message(STATUS "installed headers (${PREFIX}/include/volcl):\n  ${_installed}")
foreach(_header IN LISTS _installed)
  if(NOT _header IN_LIST _expected)
    message(FATAL_ERROR "installed a header that is not public: include/volcl/${_header}")
  endif()
  file(STRINGS ${PREFIX}/include/volcl/${_header} _first LIMIT_COUNT 1)
  if(_first MATCHES "[Ii]nternal")
    message(FATAL_ERROR "installed a header that calls itself internal: include/volcl/${_header}: ${_first}")
  endif()
  file(STRINGS ${PREFIX}/include/volcl/${_header} _quoted REGEX "#include \"")
  if(_quoted)
    message(FATAL_ERROR "include/volcl/${_header} includes by a build-tree path: ${_quoted}")
  endif()
endforeach()
foreach(_header IN LISTS _expected)
  if(NOT _header IN_LIST _installed)
    message(FATAL_ERROR "public header not installed: include/volcl/${_header}")
  endif()
endforeach()

# Versioned SONAME, and RUNPATH rather than a build-tree RPATH.
find_program(READELF readelf)
if(READELF)
  file(GLOB _libs ${PREFIX}/lib*/libvolcl.so.*.*.*)
  step(${READELF} -d ${_libs})
  if(NOT STEP_OUTPUT MATCHES "SONAME[^\n]*libvolcl\\.so\\.[0-9]+\\.[0-9]+\\]")
    message(FATAL_ERROR "libvolcl has no versioned SONAME:\n${STEP_OUTPUT}")
  endif()
  step(${READELF} -d ${PREFIX}/bin/volcl)
  if(NOT STEP_OUTPUT MATCHES "RUNPATH[^\n]*\\$ORIGIN" OR STEP_OUTPUT MATCHES "${BUILD_DIR}")
    message(FATAL_ERROR "the installed volcl has no relative RUNPATH:\n${STEP_OUTPUT}")
  endif()
endif()

# The installed CLI runs from the prefix.
step(${PREFIX}/bin/volcl --version)
if(NOT STEP_OUTPUT MATCHES "${VERSION}")
  message(FATAL_ERROR "installed `volcl --version` printed '${STEP_OUTPUT}', expected ${VERSION}")
endif()
step(${PREFIX}/bin/volcl devices)
# ... and loads its OpenImageIO module from the prefix (demo writes a PNG and an EXR).
step(${PREFIX}/bin/volcl --quiet demo -o ${WORK_DIR}/demo --phantom-size 16)
if(NOT EXISTS ${WORK_DIR}/demo/phantom.png)
  message(FATAL_ERROR "the installed `volcl demo` wrote no phantom.png:\n${STEP_OUTPUT}")
endif()

# README.md's ```cpp block is built with the consumer and run on the demo's volume, so it cannot rot.
file(READ ${PROJECT_DIR}/README.md _readme)
string(REGEX MATCH "```cpp\n([^`]*)```" _block "${_readme}")
set(_snippet "${CMAKE_MATCH_1}") # the next MATCHES resets CMAKE_MATCH_1
if(NOT _snippet MATCHES "int main")
  message(FATAL_ERROR "README.md has no ```cpp block holding a whole program (int main)")
endif()
file(WRITE ${WORK_DIR}/readme_snippet.cpp "${_snippet}")

# The consumer builds from the prefix alone: no include path into the source or build tree.
step(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/build -DCMAKE_PREFIX_PATH=${PREFIX} -DVOLCL_PREFIX=${PREFIX}
     -DREADME_SNIPPET=${WORK_DIR}/readme_snippet.cpp)
step(${CMAKE_COMMAND} --build ${WORK_DIR}/build -j2)
# Every include directory of every compile is in the prefix or the consumer's own tree (the scratch
# prefix sits inside the build tree, so directories are compared whole, not by a substring).
file(READ ${WORK_DIR}/build/compile_commands.json _commands)
string(REGEX MATCHALL "(-I|-isystem )[^ \"]+" _flags "${_commands}")
foreach(_flag IN LISTS _flags)
  string(REGEX REPLACE "^(-I|-isystem )" "" _dir "${_flag}")
  file(REAL_PATH "${_dir}" _dir)
  if(_dir MATCHES "^${PROJECT_DIR}(/|$)" AND NOT _dir MATCHES "^(${PREFIX}|${WORK_DIR}/build)(/|$)")
    message(FATAL_ERROR "the consumer compiled with an include path into the volcl tree: ${_flag}")
  endif()
endforeach()
step(${WORK_DIR}/build/consumer)
message(STATUS "${STEP_OUTPUT}")
step(${WORK_DIR}/build/readme_snippet ${WORK_DIR}/demo/marschner_lobb.nrrd)
if(NOT STEP_OUTPUT MATCHES "^41x41x41 voxels in \\[[^]]+\\], [0-9]+ bytes as a \\.vcz")
  message(FATAL_ERROR "README.md's snippet printed '${STEP_OUTPUT}', expected the demo's 41x41x41 Marschner-Lobb volume")
endif()
message(STATUS "README snippet: ${STEP_OUTPUT}")
