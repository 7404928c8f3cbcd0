"""The array argument types of the Taichi kernels (external arrays: numpy on the CPU,
ti.ndarray on a GPU), named dtype_ndim."""
import taichi as ti

i8_1d = ti.types.ndarray(dtype=ti.i8, ndim=1)
u8_1d = ti.types.ndarray(dtype=ti.u8, ndim=1)
u8_2d = ti.types.ndarray(dtype=ti.u8, ndim=2)
u16_1d = ti.types.ndarray(dtype=ti.u16, ndim=1)
u32_1d = ti.types.ndarray(dtype=ti.u32, ndim=1)
i32_1d = ti.types.ndarray(dtype=ti.i32, ndim=1)
i32_2d = ti.types.ndarray(dtype=ti.i32, ndim=2)
i64_1d = ti.types.ndarray(dtype=ti.i64, ndim=1)
i64_2d = ti.types.ndarray(dtype=ti.i64, ndim=2)
i64_3d = ti.types.ndarray(dtype=ti.i64, ndim=3)
u64_1d = ti.types.ndarray(dtype=ti.u64, ndim=1)
f64_1d = ti.types.ndarray(dtype=ti.f64, ndim=1)
f64_2d = ti.types.ndarray(dtype=ti.f64, ndim=2)
f64_3d = ti.types.ndarray(dtype=ti.f64, ndim=3)
#: compiled per element type (e.g. pixels or float coordinates)
any_1d = ti.types.ndarray(ndim=1)
