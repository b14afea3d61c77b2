"""The shortest paths of :mod:`.navigation_update` (a navigation function updated from
another), compiled by numba: imported only through :func:`.navigation_update.kernels`, which
sets numba's cache folder on import. They also run as plain Python (``kernel.py_func``).

The graph is that of :func:`.navigation._cell_graph`, read off the free-cell mask: 8-connected
free cells, edges ``w1`` (axis) and ``w2`` (diagonal), no diagonal past a blocked cell. Path
lengths ``values`` carry the Dijkstra's offset (a seed holds its distance to the goal plus one
cell, as the virtual source of :meth:`.navigation.NavigationFunction._solve` gives it) and are
sums of edge lengths in path order, as there. ``step[y, x]`` is the direction (index into
:data:`STEPS`) from a cell to its predecessor on its path, :data:`SEED` for a seed, -1 where
the cell is not reached.

The queue is a bucket queue of width ``w1 / 2``: a cell taken from the lowest bucket is final,
since a path through any cell in the same bucket is longer by at least ``w1``; so cells leave
in any order within a bucket, at constant cost. Every key waiting is within the buckets'
span of the lowest (the first keys span no more, and an edge adds at most ``w2``), so the
buckets are a ring.

A cell no path reaches takes the value of the nearest reached cell plus the distance to it
(:func:`.navigation._fill_unreached`, scipy's ``distance_transform_edt``); of several nearest
cells, scipy's is the one with the smallest column, then the smallest row, and so is the one
found here (a test holds the two to the same choice).
"""

import numba
import numpy as np

STEPS = np.array([(0, 1), (0, -1), (1, 0), (-1, 0), (1, 1), (-1, -1), (1, -1), (-1, 1)],
                 dtype=np.int64)
"""``(dy, dx)`` of the 8 neighbours: axes first, and ``STEPS[k ^ 1] == -STEPS[k]``."""
SEED = 8
"""``step`` of a seed: its predecessor is the virtual source."""
UNKNOWN = -(1 << 30)
"""Offset to the nearest reached cell of a cell new to the window (not yet known)."""


@numba.njit(cache=True, nogil=True, inline="always")
def _edge(free, y, x, k):
    """Whether the edge from free cell ``(x, y)`` along ``STEPS[k]`` exists."""
    ny, nx = free.shape
    dy, dx = STEPS[k, 0], STEPS[k, 1]
    v, u = y + dy, x + dx
    if v < 0 or v >= ny or u < 0 or u >= nx or not free[v, u]:
        return False
    return dy == 0 or dx == 0 or (free[v, x] and free[y, u])


@numba.njit(cache=True, nogil=True)
def _queue(capacity, low, high, width):
    """An empty bucket queue ``(heads, next, items, keys)`` for up to ``capacity`` entries
    whose first keys lie in ``[low, high]``, buckets ``width`` wide from ``low``."""
    slots = 16
    while slots < (high - low) / width + 16:
        slots *= 2
    return (np.full(slots, -1, np.int64), np.empty(capacity, np.int64),
            np.empty(capacity, np.int64), np.empty(capacity, np.float64))


@numba.njit(cache=True, nogil=True, inline="always")
def _put(queue, used, key, item, low, width):
    """Add ``item`` at ``key``; returns the entries used."""
    heads, following, items, keys = queue
    slot = np.int64((key - low) / width) & (heads.size - 1)
    following[used], items[used], keys[used] = heads[slot], item, key
    heads[slot] = used
    return used + 1


@numba.njit(cache=True, nogil=True, inline="always")
def _take(queue, bucket):
    """``(entry, bucket)``: an entry of the lowest non-empty bucket from ``bucket`` on (the
    queue must hold one), removed."""
    heads, following = queue[0], queue[1]
    mask = heads.size - 1
    while heads[bucket & mask] < 0:
        bucket += 1
    entry = heads[bucket & mask]
    heads[bucket & mask] = following[entry]
    return entry, bucket


@numba.njit(cache=True, nogil=True)
def _settle(free, values, step, queue, used, low, w1, w2, tol):
    """Dijkstra from the ``used`` queued entries: take the nearest, relax its edges; ``values``
    and ``step`` are updated where a path is shorter by more than ``tol``."""
    ny, nx = free.shape
    width = 0.5 * w1
    live = used
    bucket = 0
    items, keys = queue[2], queue[3]
    while live > 0:
        entry, bucket = _take(queue, bucket)
        live -= 1
        key, item = keys[entry], items[entry]
        y, x = item // nx, item % nx
        if key > values[y, x]:
            continue
        inner = 0 < y < ny - 1 and 0 < x < nx - 1
        for k in range(8):
            v, u = y + STEPS[k, 0], x + STEPS[k, 1]
            if inner:  # the same test as _edge's, without the bounds
                if not free[v, u] or (k >= 4 and not (free[v, x] and free[y, u])):
                    continue
            elif not _edge(free, y, x, k):
                continue
            length = key + (w1 if k < 4 else w2)
            if length < values[v, u] - tol:
                values[v, u] = length
                step[v, u] = k ^ 1  # the opposite direction: STEPS pairs k and k ^ 1
                used = _put(queue, used, length, v * nx + u, low, width)
                live += 1


@numba.njit(cache=True, nogil=True)
def shortest_paths(free, seeds, seed_values, w1, w2, values, step):
    """Dijkstra from ``seeds`` (flat indices, free) valued ``seed_values``: fills ``values``
    (inf where not reached) and ``step``."""
    nx = free.shape[1]
    values[:], step[:] = np.inf, -1
    low = seed_values.min()
    queue = _queue(9 * free.size + seeds.size, low, seed_values.max(), 0.5 * w1)
    used = 0
    for i in range(seeds.size):
        y, x = seeds[i] // nx, seeds[i] % nx
        if seed_values[i] < values[y, x]:
            values[y, x] = seed_values[i]
            step[y, x] = SEED
            used = _put(queue, used, seed_values[i], seeds[i], low, 0.5 * w1)
    _settle(free, values, step, queue, used, low, w1, w2, 0.0)


@numba.njit(cache=True, nogil=True)
def _lost_parent(free, step, y, x):
    """Whether the reached cell ``(x, y)`` lost the edge to its predecessor (or it left)."""
    k = step[y, x]
    if k < 0 or k == SEED:
        return False
    v, u = y + STEPS[k, 0], x + STEPS[k, 1]
    if not (0 <= v < free.shape[0] and 0 <= u < free.shape[1]):
        return True
    return not free[y, x] or not _edge(free, y, x, k)


@numba.njit(cache=True, nogil=True)
def _lost_cells(free, suspects, step):
    """The reached cells (flat, maybe repeated) that were blocked or lost the edge to their
    predecessor, found around the ``suspects`` (flat): the cells whose state changed, and the
    window's border, where a predecessor may have left."""
    ny, nx = free.shape
    found = np.empty(9 * suspects.size, np.int64)
    count = 0
    for i in range(suspects.size):
        y, x = suspects[i] // nx, suspects[i] % nx
        if free[y, x] and not _lost_parent(free, step, y, x):
            continue
        for k in range(-1, 8):
            v, u = (y, x) if k < 0 else (y + STEPS[k, 0], x + STEPS[k, 1])
            if (0 <= v < ny and 0 <= u < nx and step[v, u] >= 0
                    and (k < 0 or _lost_parent(free, step, v, u))):
                found[count] = v * nx + u
                count += 1
    return found[:count]


@numba.njit(cache=True, nogil=True)
def _cut(free, suspects, values, step, w1, w2, tol):
    """Cut the paths that used a blocked cell, a lost edge or a cell that left the window:
    in order of path length, a lost cell that has another neighbour on an intact path of the
    same length (to ``tol``: sums of the same edges in another order) takes it as predecessor;
    the others are cut (``values`` inf, ``step`` -1) and their successors looked at in turn.
    Returns the cut cells (flat)."""
    ny, nx = free.shape
    roots = _lost_cells(free, suspects, step)
    if roots.size == 0:
        return roots
    keys, width = values.ravel()[roots], 0.5 * w1
    low = keys.min()
    queue = _queue(roots.size + free.size, low, keys.max(), width)
    used = 0
    for i in range(roots.size):
        used = _put(queue, used, keys[i], roots[i], low, width)
    done = np.zeros(free.shape, np.int8)  # 1: kept, 2: cut
    lost = np.empty(free.size, np.int64)
    count = taken = bucket = 0
    while taken < used:
        entry, bucket = _take(queue, bucket)
        taken += 1
        item = queue[2][entry]
        y, x = item // nx, item % nx
        if done[y, x]:
            continue
        way = -1
        for k in range(8):
            if free[y, x] and _edge(free, y, x, k):
                v, u = y + STEPS[k, 0], x + STEPS[k, 1]
                if (done[v, u] != 2 and step[v, u] >= 0
                        and values[v, u] + (w1 if k < 4 else w2) <= values[y, x] + tol):
                    way = k
                    break
        done[y, x] = 1 if way >= 0 else 2
        if way >= 0:
            step[y, x] = way
            continue
        lost[count] = item
        count += 1
        for k in range(8):
            v, u = y + STEPS[k, 0], x + STEPS[k, 1]
            if 0 <= v < ny and 0 <= u < nx and step[v, u] == (k ^ 1) and not done[v, u]:
                used = _put(queue, used, values[v, u], v * nx + u, low, width)
    values.ravel()[lost[:count]] = np.inf
    step.ravel()[lost[:count]] = -1
    return lost[:count]


@numba.njit(cache=True, nogil=True)
def update_paths(free, changed, border, w1, w2, tol, values, step):
    """The shortest paths on the new mask ``free`` from those on the previous one (``values``,
    ``step``, moved onto the new cells; a cell new to the window is not reached), ``changed``
    (flat) being the cells free on one mask only (a cell new to the window counting as not
    free before), ``border`` the window's border cells (flat), the seeds the same cells: the
    paths through what was lost are cut (:func:`_cut`) and rebuilt from the cells around them,
    and shorter paths through what was opened spread from there, by a Dijkstra over the
    changed part only. A path counts as shorter by more than ``tol`` (m): paths of the same
    edges summed in another order are not rebuilt. Returns the number of cells cut."""
    ny, nx = free.shape
    lost = _cut(free, np.concatenate((changed, border)), values, step, w1, w2, tol)
    offers = np.empty(lost.size + 9 * changed.size, np.int64)
    offers[:lost.size] = lost
    offered = np.zeros(free.shape, np.bool_)
    count = lost.size
    for i in range(changed.size):
        y, x = changed[i] // nx, changed[i] % nx
        if not free[y, x]:
            continue
        for k in range(-1, 8):
            v, u = (y, x) if k < 0 else (y + STEPS[k, 0], x + STEPS[k, 1])
            if 0 <= v < ny and 0 <= u < nx and free[v, u] and not offered[v, u]:
                offered[v, u] = True
                offers[count] = v * nx + u
                count += 1
    better = np.full(count, np.inf)
    low, high = np.inf, -np.inf
    for i in range(count):  # each offer: its shortest path through a neighbour, if shorter
        y, x = offers[i] // nx, offers[i] % nx
        best = values[y, x] - tol
        for k in range(8):
            if free[y, x] and _edge(free, y, x, k):
                length = values[y + STEPS[k, 0], x + STEPS[k, 1]] + (w1 if k < 4 else w2)
                if length < best:
                    best = values[y, x] = better[i] = length
                    step[y, x] = k
        if better[i] < np.inf:
            low, high = min(low, better[i]), max(high, better[i])
    if low == np.inf:
        return lost.size
    queue = _queue(count + 9 * free.size, low, high, 0.5 * w1)
    used = 0
    for i in range(count):
        y, x = offers[i] // nx, offers[i] % nx
        if better[i] < np.inf and better[i] == values[y, x]:
            used = _put(queue, used, better[i], offers[i], low, 0.5 * w1)
    _settle(free, values, step, queue, used, low, w1, w2, tol)
    return lost.size


@numba.njit(cache=True, nogil=True)
def _nearest_reached(values, y, x, budget):
    """``(d2, v, u, steps)``: the reached cell ``(u, v)`` nearest to ``(x, y)`` (squared
    distance ``d2`` in cells), of several the one with the smallest ``u`` then ``v`` (the
    choice of scipy's ``distance_transform_edt``), found by walking out column by column;
    ``d2`` is -1 when that took more than ``budget`` steps."""
    ny, nx = values.shape
    best, by, bx = 1 << 62, -1, -1
    steps = k = 0
    while k * k <= best and steps <= budget:
        for column in (x - k, x + k) if k > 0 else (x, -1):
            dy = 0
            while 0 <= column < nx and k * k + dy * dy <= best and steps <= budget:
                steps += 1
                row = y - dy if y - dy >= 0 and values[y - dy, column] < np.inf else (
                    y + dy if y + dy < ny and values[y + dy, column] < np.inf else -1)
                if row >= 0:
                    d2 = k * k + dy * dy
                    if d2 < best or (d2 == best and (column, row) < (bx, by)):
                        best, by, bx = d2, row, column
                    break
                if y - dy < 0 and y + dy >= ny:
                    break
                dy += 1
        if x - k < 0 and x + k >= nx:
            break
        k += 1
    return (best if steps <= budget else -1), by, bx, steps


@numba.njit(cache=True, nogil=True)
def _refill(values, cells, count, near_dy, near_dx, budget):
    """Set the offsets ``near_dy, near_dx`` to the nearest reached cell of the ``count``
    first ``cells`` (flat, unreached); False, half done, past ``budget`` steps in all."""
    nx = values.shape[1]
    for i in range(count):
        y, x = cells[i] // nx, cells[i] % nx
        d2, v, u, steps = _nearest_reached(values, y, x, budget)
        budget -= steps
        if d2 < 0:
            return False
        near_dy[y, x], near_dx[y, x] = v - y, u - x
    return True


@numba.njit(cache=True, nogil=True)
def nearest_reached(values, near_dy, near_dx, budget):
    """``near_dy, near_dx``: for each unreached cell (``values`` inf) the offset to the nearest
    reached one (:func:`_nearest_reached`); those of reached cells are not set. False, half
    done, past ``budget`` steps in all."""
    cells = np.flatnonzero(values.ravel() == np.inf)
    return _refill(values, cells, cells.size, near_dy, near_dx, budget)


@numba.njit(cache=True, nogil=True)
def _kept_nearest(values, old_values, old_dy, old_dx, sx, sy, near_dy, near_dx, cells, front):
    """The first pass of :func:`update_nearest`: keep the old offsets of the cells unreached
    before and now whose old nearest cell is still reached, queue the other unreached cells
    (``cells``) and the newly reached cells next to an unreached one (``front``). Returns the
    two counts and the largest squared offset kept."""
    ny, nx = values.shape
    oy, ox = old_values.shape
    count = fronts = reach = 0
    for y in range(ny):
        for x in range(nx):
            inside = 0 <= y + sy < oy and 0 <= x + sx < ox
            was_reached = inside and old_values[y + sy, x + sx] < np.inf
            if values[y, x] < np.inf:
                if not was_reached:
                    for k in range(8):
                        v, u = y + STEPS[k, 0], x + STEPS[k, 1]
                        if 0 <= v < ny and 0 <= u < nx and values[v, u] == np.inf:
                            front[fronts] = y * nx + x
                            fronts += 1
                            break
                continue
            dy, dx = UNKNOWN, UNKNOWN
            if inside and not was_reached:
                dy, dx = old_dy[y + sy, x + sx], old_dx[y + sy, x + sx]
                v, u = y + dy, x + dx
                if not (0 <= v < ny and 0 <= u < nx and values[v, u] < np.inf):
                    dy = UNKNOWN
            if dy == UNKNOWN:
                cells[count] = y * nx + x
                count += 1
            else:
                reach = max(reach, dy * dy + dx * dx)
            near_dy[y, x], near_dx[y, x] = dy, dx
    return count, fronts, reach


@numba.njit(cache=True, nogil=True)
def update_nearest(values, old_values, old_dy, old_dx, sx, sy, near_dy, near_dx, budget):
    """:func:`nearest_reached` from the previous path lengths and offsets (new cell ``(x, y)``
    is old ``(x + sx, y + sy)``): an unreached cell keeps its nearest reached cell while that
    is still reached and no cell that became reached is as near (or as near and first in
    scipy's order); such a cell has an unreached neighbour (one step from it towards the cell
    is nearer), so only those are looked around, within the largest distance kept. Offsets of
    reached cells are not set."""
    ny, nx = values.shape
    cells = np.empty(values.size, np.int64)
    front = np.empty(values.size, np.int64)
    count, fronts, reach = _kept_nearest(values, old_values, old_dy, old_dx, sx, sy, near_dy,
                                         near_dx, cells, front)
    radius = int(np.sqrt(np.float64(reach))) + 1
    cost = fronts * (2 * radius + 1) ** 2
    if cost > budget:
        return nearest_reached(values, near_dy, near_dx, budget)
    for i in range(fronts):  # a kept cell's nearest: its old one, or a front cell nearer
        y, x = front[i] // nx, front[i] % nx
        for v in range(max(y - radius, 0), min(y + radius + 1, ny)):
            for u in range(max(x - radius, 0), min(x + radius + 1, nx)):
                dy, dx = near_dy[v, u], near_dx[v, u]
                if values[v, u] < np.inf or dy == UNKNOWN:
                    continue
                d2, gap2 = (v - y) ** 2 + (u - x) ** 2, dy * dy + dx * dx
                if d2 < gap2 or (d2 == gap2 and (x, y) < (u + dx, v + dy)):
                    near_dy[v, u], near_dx[v, u] = y - v, x - u
    return _refill(values, cells, count, near_dy, near_dx, budget - cost)


@numba.njit(cache=True, nogil=True)
def navigation_values(values, near_dy, near_dx, resolution, out):
    """The navigation function (m): path lengths less the Dijkstra's offset of one cell on
    reached cells, and on the others the nearest reached cell's plus the distance to it: the
    operations of :func:`.navigation._fill_unreached` in its order (the same bits)."""
    ny, nx = values.shape
    for y in range(ny):
        for x in range(nx):
            if values[y, x] < np.inf:
                out[y, x] = values[y, x] - resolution
            else:
                dy, dx = near_dy[y, x], near_dx[y, x]
                gap = np.sqrt(np.float64(dy * dy + dx * dx))
                out[y, x] = (values[y + dy, x + dx] - resolution) + gap * resolution
