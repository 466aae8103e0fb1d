"""Test-session set-up: one OpenMP/BLAS thread, as the command line sets (``stlc.settings``);
importing ``stlc`` itself leaves the process's thread counts alone."""

from stlc import settings

settings.limit_solver_threads()
