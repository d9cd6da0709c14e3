#pragma once
// Internal: runs OpenMP parallel regions with one thread while CHOLMOD works.
//
// Debian's CHOLMOD opens OpenMP parallel regions with a fixed team of 4 threads
// (CHOLMOD_OMP_NUM_THREADS, a compile-time constant) around short loops inside its supernodal
// factorisation, while the BLAS it calls (OpenBLAS) runs threads of its own. On a 2-core
// machine the waking, spinning and yielding of those teams cost more than the loops: one
// numeric factorisation of sphere2500's H takes 55 ms with them and 25 ms with one thread
// (benchmarks/RESULTS.md, "CHOLMOD's OpenMP"). The BLAS threads are left alone; they help.
//
// While a SerialOpenMp lives, the calling thread's OpenMP max-active-levels is 0, so the
// parallel regions that thread opens (CHOLMOD's) get a team of one thread; at the end of the
// outermost one the thread's value is put back. The setting is per thread (OpenMP 5, and
// libgomp since GCC 11): other threads' regions are not touched. Construct and destroy on the
// same thread (a scoped local). (With an older runtime that keeps the setting process-wide,
// two solves on different threads that overlap can leave it at 0 for the process: OpenMP
// regions elsewhere then run with one thread. Debian 12's GCC 12 keeps it per thread.) The runtime is found among the
// libraries already loaded (the one CHOLMOD brought in); where none is loaded, nothing happens.
namespace tether {
namespace internal {

class SerialOpenMp {
 public:
  SerialOpenMp();
  ~SerialOpenMp();
  SerialOpenMp(const SerialOpenMp&) = delete;
  SerialOpenMp& operator=(const SerialOpenMp&) = delete;
};

/// True where an OpenMP runtime is loaded in the process (so SerialOpenMp has an effect).
bool OpenMpRuntimeLoaded();

}  // namespace internal
}  // namespace tether
