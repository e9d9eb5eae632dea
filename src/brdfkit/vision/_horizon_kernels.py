"""Compiled horizon march of :func:`brdfkit.vision.datasets.horizon_excess`.

The readable version, :func:`brdfkit.vision.datasets.horizon_excess_reference`, marches every
surface pixel at once, one step at a time, to the step count the tallest possible occluder
needs. The kernel here marches each pixel on its own (the lights over the cores), with the
same steps and arithmetic, and stops a pixel's march early where nothing further along can
change its maximum: once the ray has left the height field's box (a straight ray does not come
back), or once even the tallest height at the nearest possible distance would fall below the
excess found (a step ``t`` lands within ``√2 / 2`` of ``p + t d``, so at least ``t - 1`` away).
The results are the same numbers (the tests compare them).

References
----------
.. [1] N. L. Max, "Horizon mapping: shadows for bump-mapped surfaces", The Visual Computer
   4(2), 1988.
"""

from __future__ import annotations

import math

import numpy as np

from brdfkit.errors import require_extra

numba = require_extra("numba")


@numba.njit(cache=True, nogil=True, parallel=True)
def horizon_excess_box(box, rows, columns, h, lights, pixel_size, out):  # pragma: no cover
    """Write into ``out`` ``(N, P)`` the excess of every light over every surface pixel: the
    march of :func:`~brdfkit.vision.datasets.horizon_excess_reference` over ``box`` (heights,
    ``-inf`` where no surface), the pixels at ``rows``, ``columns`` of heights ``h``."""
    height, width = box.shape
    h_max = h.max()
    span = h_max - h.min()
    for k in numba.prange(lights.shape[0]):
        l_x, l_y, l_z = lights[k, 0], lights[k, 1], lights[k, 2]
        planar = math.hypot(l_x, l_y)
        for p in range(h.shape[0]):
            out[k, p] = -np.inf
        if planar < 1e-12 or l_z <= 0:
            continue
        rise = pixel_size * l_z / planar
        d_col, d_row = l_x / planar, -l_y / planar
        steps = int(min(span / rise, height + width)) + 3
        for p in range(h.shape[0]):
            best = -np.inf
            for t in range(1, steps):
                if h_max - h[p] - (t - 1) * rise < best:
                    break
                r = np.rint(rows[p] + t * d_row)
                c = np.rint(columns[p] + t * d_col)
                if r < 0 or r >= height or c < 0 or c >= width:
                    break
                distance = math.hypot(r - rows[p], c - columns[p])
                best = max(best, box[int(r), int(c)] - h[p] - distance * rise)
            out[k, p] = best
