#pragma once
// Internal: how many threads the BLAS library runs its kernels on.
//
// Debian's libblas.so.3 is whichever implementation is installed (reference BLAS, OpenBLAS
// with pthreads or OpenMP, BLIS); a threaded one starts a thread per core by default and lets
// them spin between calls. Code that runs on one thread by design (the incremental smoother,
// whose fronts are small) sets the count for the duration of a call. The setter is looked up
// at run time, so nothing links against a particular BLAS; where the library has none (the
// reference BLAS) this does nothing.

namespace tether::internal {

/// The BLAS library's current thread count, or 0 where it cannot be read.
int BlasThreads();

/// Sets the BLAS library's thread count (at least 1) for this object's lifetime and restores
/// the previous count after. The count is process-wide: another thread's BLAS calls run with
/// it meanwhile (they give the same results, only on fewer cores).
class ScopedBlasThreads {
 public:
  explicit ScopedBlasThreads(int threads);
  ~ScopedBlasThreads();
  ScopedBlasThreads(const ScopedBlasThreads&) = delete;
  ScopedBlasThreads& operator=(const ScopedBlasThreads&) = delete;

 private:
  int previous_ = 0;  // 0: nothing to restore
};

}  // namespace tether::internal
