"""Private scratch grids for CPU lane-parallel kernels, claimed without per-event atomics.

Taichi's CPU backend splits a parallel loop into at most `cpu_max_num_threads` blocks of
>= 512 iterations each, so a loop over a handful of "lanes" runs on one thread. The lane
kernels therefore loop over many iterations (most of them empty) and each busy iteration
claims one of `n_slots` scratch grids for itself (one atomic per unit of work, never one
per event). With at most n_slots iterations running at once a free slot always exists.
"""
import taichi as ti


@ti.func
def claim(busy: ti.template(), n_slots: ti.i32) -> ti.i32:
    slot = -1
    while slot < 0:
        for s in range(n_slots):
            if slot < 0:
                if ti.atomic_max(busy[s], 1) == 0:
                    slot = s
    return slot


@ti.func
def release(busy: ti.template(), slot: ti.i32):
    ti.atomic_min(busy[slot], 0)
