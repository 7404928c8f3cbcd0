"""Compute kernels of evstar (math only: no I/O, no policy). Imported as evstar_kernels."""
