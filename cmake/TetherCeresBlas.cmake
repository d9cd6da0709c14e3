# Debian's Ceres package configuration finds BLAS with CMake's FindBLAS, which on a machine
# with ATLAS installed returns ATLAS's libf77blas and libatlas by path, and exports them
# through Ceres::ceres, SuiteSparse::Config, BLAS::BLAS and LAPACK::LAPACK. A binary that
# records them as dependencies puts them ahead of the BLAS the system's alternatives select
# (OpenBLAS where installed) in the symbol lookup, so CHOLMOD's dgemm/dsyrk/dtrsm bind to
# ATLAS: about twice as slow on sphere2500. Everything here needs BLAS and LAPACK only
# through the generic libblas/liblapack, so the ATLAS-specific libraries are dropped.
# Included after find_package(Ceres) by tether's build and its installed configuration.
foreach(_tether_target Ceres::ceres SuiteSparse::Config SuiteSparse::CHOLMOD SuiteSparse::SPQR BLAS::BLAS
                       LAPACK::LAPACK)
  if(TARGET ${_tether_target})
    get_target_property(_tether_libs ${_tether_target} INTERFACE_LINK_LIBRARIES)
    if(_tether_libs)
      list(FILTER _tether_libs EXCLUDE REGEX "lib(f77blas|atlas|cblas|ptf77blas|ptcblas)\\.so")
      set_target_properties(${_tether_target} PROPERTIES INTERFACE_LINK_LIBRARIES "${_tether_libs}")
    endif()
  endif()
endforeach()
unset(_tether_libs)
unset(_tether_target)
