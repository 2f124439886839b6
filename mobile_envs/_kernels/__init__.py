"""numba plumbing under everything else: angle wrapping, numpy's PCG64 draws in compiled code,
the threads parallel kernels run on, per-model kernel specialization and the kernel cache."""
