# The coupling API as a package: `cmake --install` puts demfem::coupling_api and demfem::remote
# under PREFIX, examples/cpp_dem_server is configured and built against that installed package
# alone (find_package(demfem)), and its self-check (serve, then drive it through the remote proxy)
# reads back the spring force of its elastic foundation: F = -k d = 20 N for k = 2e4 N/m, d = -1 mm.
# Usage: cmake -DBUILD_DIR=<build> -DSOURCE_DIR=<source> -DWORK_DIR=<empty dir> -DCXX=<compiler> -P example_dem_server.cmake
file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix} RESULT_VARIABLE rc OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install failed (${rc})")
endif()
foreach(file include/demfem/adapter/coupling_api.hpp include/demfem/adapter/server.hpp lib/cmake/demfem/demfemConfig.cmake)
  if(NOT EXISTS ${prefix}/${file})
    message(FATAL_ERROR "${file} is not installed")
  endif()
endforeach()
file(GLOB_RECURSE zmq_headers ${prefix}/include/*zmq*)
if(zmq_headers)
  message(FATAL_ERROR "ZeroMQ headers installed with the coupling API: ${zmq_headers}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/cpp_dem_server -B ${WORK_DIR}/build
                        -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_BUILD_TYPE=Release
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "configuring the example against the installed package failed:\n${out}\n${err}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "building the example failed:\n${out}\n${err}")
endif()
execute_process(COMMAND ${WORK_DIR}/build/example-dem-server --self-check RESULT_VARIABLE rc OUTPUT_VARIABLE out
                ERROR_VARIABLE err TIMEOUT 60)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "example-dem-server --self-check exits with ${rc}:\n${out}\n${err}")
endif()
string(JSON force GET "${out}" force_z_N)
# Closed form: -k d = -(2e4 N/m)(-1e-3 m) = 20 N, to rounding.
if(force LESS 19.999999 OR force GREATER 20.000001)
  message(FATAL_ERROR "the example's spring force read through the protocol is ${force} N, expected 20 N")
endif()
file(REMOVE_RECURSE ${WORK_DIR})
message(STATUS "the example DEM server builds against the installed package and answers 20 N")
