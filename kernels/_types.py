"""Numba type aliases for explicit, eager kernel signatures."""

from numba import types

I64 = types.int64
F64 = types.float64
B1 = types.boolean

# inputs: read-only, C order (accept frozen and writeable arrays alike)
I64_1D = types.Array(types.int64, 1, "C", readonly=True)
I64_2D = types.Array(types.int64, 2, "C", readonly=True)
F64_1D = types.Array(types.float64, 1, "C", readonly=True)
B1_1D = types.Array(types.boolean, 1, "C", readonly=True)
U8_1D = types.Array(types.uint8, 1, "C", readonly=True)  # bytes of a file

# outputs: allocated inside the kernel
I64_1D_OUT = types.int64[::1]
I64_2D_OUT = types.int64[:, ::1]
F64_1D_OUT = types.float64[::1]
B1_1D_OUT = types.boolean[::1]

# in-place outputs (arguments named out_*)
I64_1D_W = types.int64[::1]
B1_1D_W = types.boolean[::1]
I64_2D_W = types.int64[:, ::1]
F64_1D_W = types.float64[::1]
