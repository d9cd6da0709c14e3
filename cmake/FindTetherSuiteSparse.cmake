# Finds CHOLMOD and SuiteSparseQR (Debian's libsuitesparse-dev ships no CMake config).
# Defines the imported targets TetherSuiteSparse::cholmod, TetherSuiteSparse::spqr and
# TetherSuiteSparse::camd (constrained minimum degree, the incremental smoother's ordering).
find_path(TETHER_SUITESPARSE_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
find_library(TETHER_CHOLMOD_LIBRARY cholmod)
find_library(TETHER_SPQR_LIBRARY spqr)
find_library(TETHER_CAMD_LIBRARY camd)
find_library(TETHER_SUITESPARSECONFIG_LIBRARY suitesparseconfig)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(TetherSuiteSparse
  REQUIRED_VARS TETHER_SUITESPARSE_INCLUDE_DIR TETHER_CHOLMOD_LIBRARY TETHER_SPQR_LIBRARY
                TETHER_CAMD_LIBRARY TETHER_SUITESPARSECONFIG_LIBRARY)
if(TetherSuiteSparse_FOUND AND NOT TARGET TetherSuiteSparse::cholmod)
  add_library(TetherSuiteSparse::cholmod UNKNOWN IMPORTED)
  set_target_properties(TetherSuiteSparse::cholmod PROPERTIES
    IMPORTED_LOCATION ${TETHER_CHOLMOD_LIBRARY}
    INTERFACE_INCLUDE_DIRECTORIES ${TETHER_SUITESPARSE_INCLUDE_DIR}
    INTERFACE_LINK_LIBRARIES ${TETHER_SUITESPARSECONFIG_LIBRARY})
  add_library(TetherSuiteSparse::spqr UNKNOWN IMPORTED)
  set_target_properties(TetherSuiteSparse::spqr PROPERTIES
    IMPORTED_LOCATION ${TETHER_SPQR_LIBRARY}
    INTERFACE_INCLUDE_DIRECTORIES ${TETHER_SUITESPARSE_INCLUDE_DIR}
    INTERFACE_LINK_LIBRARIES "TetherSuiteSparse::cholmod")
  add_library(TetherSuiteSparse::camd UNKNOWN IMPORTED)
  set_target_properties(TetherSuiteSparse::camd PROPERTIES
    IMPORTED_LOCATION ${TETHER_CAMD_LIBRARY}
    INTERFACE_INCLUDE_DIRECTORIES ${TETHER_SUITESPARSE_INCLUDE_DIR}
    INTERFACE_LINK_LIBRARIES ${TETHER_SUITESPARSECONFIG_LIBRARY})
endif()
