# Finds Debian's libliggghts (LIGGGHTS-PUBLIC 3.8), which ships neither a CMake nor a pkg-config file.
find_path(LIGGGHTS_INCLUDE_DIR library.h PATH_SUFFIXES liggghts)
find_library(LIGGGHTS_LIBRARY NAMES liggghts)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(LIGGGHTS REQUIRED_VARS LIGGGHTS_INCLUDE_DIR LIGGGHTS_LIBRARY)
if(LIGGGHTS_FOUND AND NOT TARGET LIGGGHTS::LIGGGHTS)
  add_library(LIGGGHTS::LIGGGHTS UNKNOWN IMPORTED)
  set_target_properties(LIGGGHTS::LIGGGHTS PROPERTIES
    IMPORTED_LOCATION "${LIGGGHTS_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${LIGGGHTS_INCLUDE_DIR}")
endif()
