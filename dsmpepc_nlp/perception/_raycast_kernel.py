"""The beam traversal of :mod:`.raycast` compiled (numba): the kernel alone, imported only
through :func:`.raycast._compiled_kernel` (numba's cache folder is set on import). The same
operations in the same order as :func:`.raycast.traverse_numpy`, so both set the same cells
bit for bit (a test holds them to it)."""

import math

import numba


@numba.njit(cache=True, nogil=True)
def traverse_loops(u0, v0, u1, v1, exclude, n, mask):
    """The traversal (see :func:`traverse`) beam by beam; compiled."""
    for beam in range(u1.size):
        du = u1[beam] - u0
        dv = v1[beam] - v0
        ix = math.floor(u0) if du >= 0.0 else math.ceil(u0) - 1
        iy = math.floor(v0) if dv >= 0.0 else math.ceil(v0) - 1
        if 0 <= ix < n and 0 <= iy < n and iy * n + ix != exclude[beam]:
            mask[iy * n + ix] = True
        for axis in range(2):
            a0, b0, da, db = (u0, v0, du, dv) if axis == 0 else (v0, u0, dv, du)
            a1 = u1[beam] if axis == 0 else v1[beam]
            if da > 0.0:
                first, last = math.floor(a0) + 1, math.ceil(a1) - 1
            elif da < 0.0:
                first, last = math.floor(a1) + 1, math.ceil(a0) - 1
            else:
                continue
            for line in range(first, last + 1):
                t = (line - a0) / da
                b = b0 + t * db
                cell_b = math.floor(b) if db >= 0.0 else math.ceil(b) - 1
                cell_a = line if da > 0.0 else line - 1
                ix, iy = (cell_a, cell_b) if axis == 0 else (cell_b, cell_a)
                if 0 <= ix < n and 0 <= iy < n and iy * n + ix != exclude[beam]:
                    mask[iy * n + ix] = True
