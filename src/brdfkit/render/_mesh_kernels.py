"""The shadow rays of a mesh as one numba loop.

:meth:`brdfkit.render.mesh.MeshScene.unoccluded` (the readable reference, ``render/mesh.py``:
:func:`~brdfkit.render.mesh.shadow_rays`) turns segments into Embree's rays: for each segment
of positive length from a point :math:`x` with geometric normal :math:`n` along
:math:`\\omega`, the origin :math:`x + \\epsilon\\,\\mathrm{sign}(n\\cdot\\omega)\\,n`, the
direction :math:`\\omega` and the far end :math:`\\max(d - 2\\epsilon, 0)`, in single precision.
In NumPy that takes a dozen arrays the size of the batch of rays (gathers of the points and
normals, the side, the offset, the copies to float32), each a pass over memory with the GIL
held. :func:`shadow_rays` writes the rays in one pass, without the GIL, where every point
carries the same number of segments (a pixel's samples): the same arithmetic in the same
order, so the same rays bit for bit (``tests/render/test_mesh.py`` holds the two equal).
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np


@functools.cache
def shadow_rays() -> Callable[..., int]:
    """The numba ``rays(points, normals, wi, distance, eps, origins, directions, far, index)``:
    ``points`` and ``normals`` ``(P, 3)`` float64, ``wi`` ``(P, K, 3)`` and ``distance``
    ``(P, K)``, one ray for each segment with ``distance > 0`` written to the next row of
    ``origins`` and ``directions`` ``(≥ rays, 3)``, ``far`` ``(≥ rays,)`` (float32) and
    ``index`` (its flat index ``p K + k``); returns how many rays it wrote. Its machine code
    is kept on disk."""
    from brdfkit.compiled import kernel_tools as tools

    largest = np.float64(np.finfo(np.float32).max)

    @tools.cached_jit("mesh-shadow-rays")
    def rays(points: np.ndarray, normals: np.ndarray, wi: np.ndarray, distance: np.ndarray,
             eps: float, origins: np.ndarray, directions: np.ndarray, far: np.ndarray,
             index: np.ndarray) -> int:  # fmt: skip
        count, per_point = distance.shape
        written = 0
        for p in range(count):
            n0, n1, n2 = normals[p, 0], normals[p, 1], normals[p, 2]
            for k in range(per_point):
                d = distance[p, k]
                if not d > 0:
                    continue
                w0, w1, w2 = (
                    np.float64(wi[p, k, 0]),
                    np.float64(wi[p, k, 1]),
                    np.float64(wi[p, k, 2]),
                )
                offset = eps * np.sign(n0 * w0 + n1 * w1 + n2 * w2)
                origins[written, 0] = np.float32(points[p, 0] + offset * n0)
                origins[written, 1] = np.float32(points[p, 1] + offset * n1)
                origins[written, 2] = np.float32(points[p, 2] + offset * n2)
                directions[written, 0] = np.float32(w0)
                directions[written, 1] = np.float32(w1)
                directions[written, 2] = np.float32(w2)
                end = d - 2 * eps
                end = 0.0 if end < 0.0 else end
                far[written] = np.float32(largest if end > largest else end)
                index[written] = p * per_point + k
                written += 1
        return written

    return rays


__all__ = ["shadow_rays"]
