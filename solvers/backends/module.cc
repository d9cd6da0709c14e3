// The entry point of libtether_backends.so: its table of functions (../src/backends.h).
#include "backend_functions.h"
#include "backends.h"
#include "blas.h"

extern "C" const tether::internal::BackendTable* tether_backends_v1() {
  static const tether::internal::BackendTable table = [] {
    tether::internal::BackendTable t;
    t.make_cholmod = tether::backends::MakeCholmod;
    t.make_spqr = tether::backends::MakeSpqr;
    t.make_cholmod_covariance = tether::backends::MakeCholmodCovariance;
    t.make_qr_covariance = tether::backends::MakeQrCovariance;
    t.optimize_with_ceres = tether::backends::OptimizeWithCeres;
    t.dsyrk = dsyrk_;
    t.dtrsm = dtrsm_;
    t.dpotrf = dpotrf_;
    return t;
  }();
  return &table;
}
