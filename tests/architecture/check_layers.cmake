# Fails when a library includes a header of a library it may not depend on (docs/architecture.md section 1),
# or when LIGGGHTS/MPI headers appear outside the LIGGGHTS backend's .cpp files and VTK headers outside
# vtkio/src/vtk_files.cpp (pimpl rule).
# Usage: cmake -DSOURCE_DIR=<root> -P check_layers.cmake
set(allowed_study "study")
set(allowed_protocol "protocol")
set(allowed_vtkio "vtkio")
set(allowed_adapter "adapter;protocol;study")
set(allowed_fem "fem;adapter;vtkio;study")
# The DEM formulas both backends share: above study, below the backends.
set(allowed_backends/physics "backends/physics;study")
set(allowed_backends/builtin "backends/builtin;backends/physics;adapter;vtkio;study")
set(allowed_backends/liggghts "backends/liggghts;backends/physics;adapter;study")
set(allowed_analysis "analysis;vtkio")
# campaign reruns the model: above fem, the backends and analysis (analysis stays simulation-free).
set(allowed_campaign "campaign;analysis;vtkio;fem;backends/builtin;backends/physics;adapter;study")

set(violations "")
foreach(layer study protocol vtkio adapter fem backends/physics backends/builtin backends/liggghts analysis campaign)
  file(GLOB_RECURSE files ${SOURCE_DIR}/${layer}/*.hpp ${SOURCE_DIR}/${layer}/*.h ${SOURCE_DIR}/${layer}/*.cpp)
  foreach(f ${files})
    file(STRINGS ${f} includes REGEX "^[ \t]*#[ \t]*include[ \t]*[<\"]demfem/")
    foreach(line ${includes})
      string(REGEX MATCH "demfem/([a-z_]+)/" m "${line}")
      set(target "${CMAKE_MATCH_1}")
      if(target STREQUAL "backends")
        string(REGEX MATCH "demfem/backends/([a-z_]+)/" m "${line}")
        set(target "backends/${CMAKE_MATCH_1}")
      endif()
      list(FIND allowed_${layer} "${target}" ok)
      if(ok EQUAL -1)
        file(RELATIVE_PATH rel ${SOURCE_DIR} ${f})
        string(APPEND violations "  ${rel}: layer '${layer}' may not include '${target}' (${line})\n")
      endif()
    endforeach()
  endforeach()
endforeach()

# Fails on a file outside `allowed` (a regular expression of paths relative to the root) that
# includes a header matching `headers`; `what` says where those headers belong.
function(check_external_headers allowed headers what)
  foreach(f ${all_sources})
    file(RELATIVE_PATH rel ${SOURCE_DIR} ${f})
    if(rel MATCHES "^(build|tests/architecture)" OR rel MATCHES "${allowed}")
      continue()
    endif()
    file(STRINGS ${f} ext REGEX "^[ \t]*#[ \t]*include[ \t]*[<\"](${headers})")
    if(ext)
      string(APPEND violations "  ${rel}: ${what} (${ext})\n")
    endif()
  endforeach()
  set(violations "${violations}" PARENT_SCOPE)
endfunction()

file(GLOB_RECURSE all_sources ${SOURCE_DIR}/*.hpp ${SOURCE_DIR}/*.h ${SOURCE_DIR}/*.cpp)
# External C libraries only inside the LIGGGHTS backend's .cpp files.
check_external_headers("^backends/liggghts/src/.*\\.cpp$" "mpi\\.h|lammps\\.h|library\\.h|liggghts/"
                       "LIGGGHTS/MPI headers belong only in backends/liggghts/src/*.cpp")
# VTK only inside vtkio/src/vtk_files.cpp (the one .cpp behind vtkio/include/demfem/vtkio/vtk_files.hpp).
check_external_headers("^vtkio/src/vtk_files\\.cpp$" "vtk[A-Z][A-Za-z0-9]*\\.h"
                       "VTK headers belong only in vtkio/src/vtk_files.cpp")

if(violations)
  message(FATAL_ERROR "dependency direction violated:\n${violations}")
endif()
message(STATUS "layers respected")
