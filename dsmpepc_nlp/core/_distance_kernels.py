"""The loops of :mod:`.distance_update` (the signed distance of a grid updated from another),
compiled by numba: imported only through :func:`.distance_update.kernels`, which sets numba's
cache folder on import. They also run as plain Python (``kernel.py_func``).

Distances are squared and in half cells, so they are exact integers: from a cell centre to the
square of a cell ``k`` cells away along an axis the gap is ``max(2 k - 1, 0)`` half cells (see
:func:`.grid._distance_to_squares`), and the distance to the nearest square is the minimum over
squares of ``gap(|dx|)^2 + gap(|dy|)^2``. Separably: ``G[y, x]``, the squared gap to the nearest
target of column ``x`` (:func:`column_squares`), then along each row
``D[y, x] = min over X of gap(|x - X|)^2 + G[y, X]``. The second step is a lower envelope of
parabolas (Felzenszwalb and Huttenlocher): column ``X`` is reached from its left by the parabola
centred at half position ``2 X + 1`` and from its right by that at ``2 X - 1``, so half position
``2 j - 1`` holds the parabola of height ``min(G[y, j - 1], G[y, j])``; the value at ``x`` is the
smaller of ``G[y, x]`` and the envelope at ``2 x``. Heights and centres are integers and the
envelope's breakpoints are kept as fractions, compared by cross-multiplication: exact.

Along a row, the column that is nearest (the leftmost of ties) never moves left as ``x`` grows
(for columns ``A < B``, ``gap(|x - A|)^2 - gap(|x - B|)^2`` never decreases), so the cells that
columns leaving (or entering) at one end of a row were (or become) nearest to are a run at that
end: :func:`update_rows` finds it by walking in from the end.

:func:`block_ring` serves :mod:`.navigation_update`: the blocked cells of the ring around a
map that a navigation window adds.
"""

import numba
import numpy as np

INF = 1 << 40
"""Squared distance of "no such cell" (far above any real one; a sum of two stays exact)."""
_NONE = 1 << 30
RUN_LIMIT = 24
"""Cells of a row beyond which a row's run is recomputed by the envelope, not cell by cell."""


@numba.njit(cache=True, nogil=True, inline="always")
def _gap2(k):
    """Squared half-cell gap from a centre to a square ``k`` >= 0 cells away along one axis."""
    return 0 if k == 0 else (2 * k - 1) * (2 * k - 1)


@numba.njit(cache=True, nogil=True)
def column_squares(occ, target, out):
    """``out[y, x]``: squared half-cell gap from cell ``(x, y)`` to the nearest cell of its
    column with ``occ == target`` (for ``target`` False, rows -1 and ny count as such: the
    world outside is free); :data:`INF` where the column has none."""
    ny, nx = occ.shape
    last = np.full(nx, -1 if not target else -_NONE, np.int64)
    for y in range(ny):
        for x in range(nx):
            if occ[y, x] == target:
                last[x] = y
            out[y, x] = y - last[x]
    last[:] = ny if not target else ny + _NONE
    for y in range(ny - 1, -1, -1):
        for x in range(nx):
            if occ[y, x] == target:
                last[x] = y
            g = min(out[y, x], last[x] - y)
            out[y, x] = INF if g >= _NONE else _gap2(g)


@numba.njit(cache=True, nogil=True)
def envelope_row(columns, y, outside, row, centres, heights, starts):
    """``row[x]`` for every x: the squared distance along row ``y`` from the column distances
    ``columns`` (see the module), ``outside`` being the columns' value beyond the grid.
    ``centres``, ``heights`` (nx + 1) and ``starts`` (nx + 2, 2) are work space: the
    envelope's parabolas and where each starts, as a fraction (numerator, denominator > 0)."""
    nx = columns.shape[1]
    k = -1
    for j in range(nx + 1):
        h = min(columns[y, j - 1] if j >= 1 else outside, columns[y, j] if j < nx else outside)
        if h >= INF:
            continue
        c = 2 * j - 1
        numerator = denominator = 1
        while k >= 0:
            numerator = (h + c * c) - (heights[k] + centres[k] * centres[k])
            denominator = 2 * (c - centres[k])
            if k == 0 or numerator * starts[k, 1] > starts[k, 0] * denominator:
                break
            k -= 1
        k += 1
        centres[k], heights[k] = c, h
        starts[k, 0], starts[k, 1] = numerator, denominator
    at = 0
    for x in range(nx):
        value = columns[y, x]
        if k >= 0:
            q = 2 * x
            while at < k and starts[at + 1, 0] < q * starts[at + 1, 1]:
                at += 1
            d = q - centres[at]
            value = min(value, d * d + heights[at])
        row[x] = value


@numba.njit(cache=True, nogil=True)
def _search(columns, y, x, outside):
    """The squared distance at ``(x, y)`` by walking out along the row from ``x`` until the gap
    alone reaches the best found: it costs the distance, not the row."""
    nx = columns.shape[1]
    best = columns[y, x]
    k = 1
    while True:
        ak = _gap2(k)
        if ak >= best:
            break
        lo, hi = x - k, x + k
        left = columns[y, lo] if lo >= 0 else outside
        right = columns[y, hi] if hi < nx else outside
        best = min(best, ak + min(left, right))
        if lo < 0 and hi >= nx:
            break
        k += 1
    return best


@numba.njit(cache=True, nogil=True)
def _nearest_of(columns, y, x, first, last, shift):
    """Smallest ``gap(|x - X|)^2 + columns[y, X + shift]`` over ``first <= X < last``."""
    best = INF
    for column in range(first, last):
        best = min(best, _gap2(abs(x - column)) + columns[y, column + shift])
    return best


@numba.njit(cache=True, nogil=True)
def _store(table, y, x, value, before, occ, resolution, signed):
    """Set ``table[y, x]`` and, on a free cell whose value is not ``before``, ``signed``: the
    operations of :attr:`.grid.OccupancyGrid.signed_distance` in its order (the same bits)."""
    table[y, x] = value
    if value != before and not occ[y, x]:
        signed[y, x] = 0.5 * np.sqrt(np.float64(value)) * resolution


@numba.njit(cache=True, nogil=True)
def _signed_row(table, old, y, yo, sx, xa, xb, occ, resolution, signed):
    """:func:`_store` along row ``y``, whose old values are ``old[yo, x + sx]`` for ``xa <= x
    < xb``."""
    nx = table.shape[1]
    for x in range(nx):
        value = table[y, x]
        if occ[y, x] or (xa <= x < xb and value == old[yo, x + sx]):
            continue
        signed[y, x] = 0.5 * np.sqrt(np.float64(value)) * resolution


@numba.njit(cache=True, nogil=True)
def _kept_runs(old_cols, old, yo, sx, table, y, xa, xb):
    """``(lo, hi)``: the cells ``[xa, lo)`` and ``[hi, xb)`` of row ``y`` whose nearest
    column may have left the grid (on its left, on its right), the rest keeping their old
    values; ``table`` holds the old values on the kept columns ``[xa, xb)``."""
    ox = old.shape[1]
    lo, hi = xa, xb
    if xa + sx > 0:
        while lo < xb and _nearest_of(old_cols, yo, lo, -sx, xa, sx) <= table[y, lo]:
            lo += 1
    if xb + sx < ox:
        while hi > lo and _nearest_of(old_cols, yo, hi - 1, xb, ox - sx, sx) <= table[y, hi - 1]:
            hi -= 1
    return lo, hi


@numba.njit(cache=True, nogil=True)
def update_rows(occ, columns, old_cols, old, sx, sy, resolution, table, signed):
    """The squared distances to the occupied squares, ``table`` (filled here), from the
    previous grid's (``old``, its column distances ``old_cols``; new cell ``(x, y)`` is old
    ``(x + sx, y + sy)``) and the new column distances ``columns``; ``signed`` (holding the
    previous signed distances where the grids overlap) is rewritten on the free cells whose
    value changed. A row whose column distances changed on the shared columns is recomputed
    (:func:`envelope_row`); in the others only the runs of cells at its ends that lost or may
    gain their nearest column (see the module) are."""
    ny, nx = occ.shape
    oy, ox = old.shape
    centres = np.empty(nx + 1, np.int64)
    heights = np.empty(nx + 1, np.int64)
    starts = np.empty((nx + 2, 2), np.int64)
    xa, xb = max(0, -sx), min(nx, ox - sx)
    for y in range(ny):
        yo = y + sy
        same = 0 <= yo < oy and xa < xb
        x = xa
        while same and x < xb:
            same = columns[y, x] == old_cols[yo, x + sx]
            x += 1
        lo, hi = xa, xa
        if same:
            for x in range(xa, xb):
                table[y, x] = old[yo, x + sx]
            lo, hi = _kept_runs(old_cols, old, yo, sx, table, y, xa, xb)
        redo = (lo - xa) + (xb - hi) + xa + (nx - xb)
        if not same or redo > RUN_LIMIT:
            envelope_row(columns, y, INF, table[y], centres, heights, starts)
            _signed_row(table, old, y, yo, sx, xa if 0 <= yo < oy else nx, xb, occ,
                        resolution, signed)
            continue
        for x in range(0, lo):
            before = table[y, x] if x >= xa else -1
            _store(table, y, x, _search(columns, y, x, INF), before, occ, resolution, signed)
        for x in range(hi, nx):
            before = table[y, x] if x < xb else -1
            _store(table, y, x, _search(columns, y, x, INF), before, occ, resolution, signed)
        x = lo
        while x < hi and xa > 0:
            near = _nearest_of(columns, y, x, 0, xa, 0)
            if near >= table[y, x]:
                break
            _store(table, y, x, near, table[y, x], occ, resolution, signed)
            x += 1
        x = hi - 1
        while x >= lo and xb < nx:
            near = _nearest_of(columns, y, x, xb, nx, 0)
            if near >= table[y, x]:
                break
            _store(table, y, x, near, table[y, x], occ, resolution, signed)
            x -= 1


@numba.njit(cache=True, nogil=True)
def _free_column(occ, y, x, limit):
    """Squared half-cell gap from ``(x, y)`` to the nearest free cell of column ``x`` (rows
    beyond the grid are free), or ``limit`` when it is no less."""
    ny, nx = occ.shape
    if x < 0 or x >= nx:
        return 0
    k = 0
    while _gap2(k) < limit:
        if y - k < 0 or not occ[y - k, x] or y + k >= ny or not occ[y + k, x]:
            return _gap2(k)
        k += 1
    return limit


@numba.njit(cache=True, nogil=True)
def to_free(occ, resolution, signed, budget):
    """``signed`` on every occupied cell: minus the distance to the nearest free square (the
    world outside the grid is free), walking out from the cell (thin obstacles cost a few
    steps). Returns False, leaving the work half done, once more than ``budget`` steps were
    needed (thick obstacles: :func:`to_free_rows` then)."""
    ny, nx = occ.shape
    steps = 0
    for y in range(ny):
        for x in range(nx):
            if not occ[y, x]:
                continue
            best = _free_column(occ, y, x, INF)
            k = 1
            while _gap2(k) < best:
                gap = _gap2(k)
                left = _free_column(occ, y, x - k, best - gap)
                right = _free_column(occ, y, x + k, best - gap)
                best = min(best, gap + min(left, right))
                steps += k
                k += 1
            if steps > budget:
                return False
            signed[y, x] = -(0.5 * np.sqrt(np.float64(best))) * resolution
    return True


@numba.njit(cache=True, nogil=True)
def to_free_rows(occ, columns, resolution, signed):
    """:func:`to_free` by rows: the envelope of the column distances to free cells
    ``columns`` (:func:`column_squares` with target False) on every row with an occupied
    cell."""
    ny, nx = occ.shape
    row = np.empty(nx, np.int64)
    centres = np.empty(nx + 1, np.int64)
    heights = np.empty(nx + 1, np.int64)
    starts = np.empty((nx + 2, 2), np.int64)
    for y in range(ny):
        if not occ[y].any():
            continue
        envelope_row(columns, y, 0, row, centres, heights, starts)
        for x in range(nx):
            if occ[y, x]:
                signed[y, x] = -(0.5 * np.sqrt(np.float64(row[x]))) * resolution


@numba.njit(cache=True, nogil=True)
def _block_around(y, x, k, shape, resolution, inflation_radius, free, x0, y0):
    """Clear ``free`` on the cells outside the map (``shape``) within ``k`` cells of it that
    occupied cell ``(x, y)`` holds within ``inflation_radius`` (see :func:`block_ring`)."""
    ny, nx = shape
    for v in range(max(y - k, -k), min(y + k, ny + k - 1) + 1):
        gy = abs(v - y)
        row = 0 if gy == 0 else (2 * gy - 1) ** 2
        for u in range(max(x - k, -k), min(x + k, nx + k - 1) + 1):
            if 0 <= v < ny and 0 <= u < nx:
                continue
            gx = abs(u - x)
            n = row + (0 if gx == 0 else (2 * gx - 1) ** 2)
            if 0.5 * np.sqrt(np.float64(n)) * resolution <= inflation_radius:
                free[v - y0, u - x0] = False


@numba.njit(cache=True, nogil=True)
def block_ring(occ, k, resolution, inflation_radius, free, x0, y0):
    """Clear ``free`` (a window whose cell ``(0, 0)`` is map cell ``(x0, y0)``) on the cells
    outside the map within ``k`` cells of it whose signed distance (``0.5 sqrt(n)`` cells to
    the nearest occupied square, the operations of the grid's) is at most
    ``inflation_radius``: the ring :func:`.navigation._free_cells` computes on a crop. Only
    the occupied cells within ``k`` of the map's edge can reach it."""
    ny, nx = occ.shape
    for y in range(ny):
        edge_row = y < k or y >= ny - k
        x = 0
        while x < nx:
            if occ[y, x]:
                _block_around(y, x, k, occ.shape, resolution, inflation_radius, free, x0, y0)
            x += 1 if edge_row or x < k - 1 or x >= nx - k else nx - k - x
