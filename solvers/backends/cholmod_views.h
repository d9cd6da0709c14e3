#pragma once
// Internal: CHOLMOD headers that borrow tether's arrays (no copy), for the solver and the
// covariance code alike.
#include <cholmod.h>

#include <cstring>

#include "tether/core/linear_solver.h"

namespace tether {
namespace internal {

/// A cholmod_sparse (int indices) over a matrix view; stype 1: the upper triangle is used.
inline cholmod_sparse CholmodView(const SparseMatrixView& a, int stype) {
  cholmod_sparse s;
  std::memset(&s, 0, sizeof(s));
  s.nrow = a.rows;
  s.ncol = a.cols;
  s.nzmax = a.colptr[a.cols];
  s.p = const_cast<int*>(a.colptr);
  s.i = const_cast<int*>(a.rowind);
  s.x = const_cast<double*>(a.values);
  s.stype = stype;
  s.itype = CHOLMOD_INT;
  s.xtype = CHOLMOD_REAL;
  s.dtype = CHOLMOD_DOUBLE;
  s.sorted = 1;
  s.packed = 1;
  return s;
}

/// A cholmod_dense over a column-major rows x cols array.
inline cholmod_dense DenseView(double* x, long rows, long cols = 1) {
  cholmod_dense d;
  std::memset(&d, 0, sizeof(d));
  d.nrow = static_cast<std::size_t>(rows);
  d.ncol = static_cast<std::size_t>(cols);
  d.nzmax = static_cast<std::size_t>(rows * cols);
  d.d = static_cast<std::size_t>(rows);
  d.x = x;
  d.xtype = CHOLMOD_REAL;
  d.dtype = CHOLMOD_DOUBLE;
  return d;
}

}  // namespace internal
}  // namespace tether
