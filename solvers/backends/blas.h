#pragma once
// Internal to the back-end module: the BLAS and LAPACK routines tether calls directly on large
// dense blocks, here and (through the module's table, ../src/backends.h) in the incremental
// smoother. The library is the one CHOLMOD runs on: Debian's libblas.so.3 and liblapack.so.3,
// OpenBLAS where installed, which picks its kernels for the CPU at run time. Column-major,
// Fortran calling convention: every argument by pointer.
extern "C" {
void dsymm_(const char* side, const char* uplo, const int* m, const int* n, const double* alpha, const double* a,
            const int* lda, const double* b, const int* ldb, const double* beta, double* c, const int* ldc);
void dgemm_(const char* ta, const char* tb, const int* m, const int* n, const int* k, const double* alpha,
            const double* a, const int* lda, const double* b, const int* ldb, const double* beta, double* c,
            const int* ldc);
void dtrsm_(const char* side, const char* uplo, const char* ta, const char* diag, const int* m, const int* n,
            const double* alpha, const double* a, const int* lda, double* b, const int* ldb);
void dsyrk_(const char* uplo, const char* trans, const int* n, const int* k, const double* alpha, const double* a,
            const int* lda, const double* beta, double* c, const int* ldc);
void dpotrf_(const char* uplo, const int* n, double* a, const int* lda, int* info);
void dpotri_(const char* uplo, const int* n, double* a, const int* lda, int* info);
}
