r"""Normal integration: a depth map from a normal map.

Frame (as :mod:`brdfkit.vision`): normals ``n = (n_x, n_y, n_z)`` with x right, y up, z towards
the camera; pixels ``(u, v)`` = (column, row), rows going down. Every solver returns **depth**:
the distance along the optical axis, growing *away* from the camera (what ``depth_gt`` of
DiLiGenT holds), NaN outside the mask.

Orthographic projection (pixel spacing is the unit of depth): the depth gradient is

.. math:: \partial_u d = n_x / n_z, \qquad \partial_v d = -n_y / n_z,

and depth is known up to an additive constant, fixed here so that the nearest mask pixel is
at 0.

Perspective projection with intrinsics ``K`` (focal lengths ``f_x, f_y``, principal point
``c_x, c_y``): a pixel sees the point ``d r`` with ``r = ((u - c_x)/f_x, (v - c_y)/f_y, 1)`` in
the OpenCV frame (y down, z forward), where the normal is ``m = (n_x, -n_y, -n_z)``. From
``m . \partial(d r) = 0`` the gradient of the log-depth ``\tilde d = \log d`` is

.. math:: \partial_u \tilde d = -\frac{m_x}{f_x\, (m \cdot r)}, \qquad
          \partial_v \tilde d = -\frac{m_y}{f_y\, (m \cdot r)},

and depth is known up to a scale, fixed so that the geometric mean of the depth over the mask
is 1 (Durou, Aujol & Courteille 2009; Quéau, Durou & Aujol 2018).

Solvers: :func:`frankot_chellappa` (FFT projection onto integrable fields, periodic, the whole
rectangle), :func:`poisson_dct` (the Poisson equation with Neumann boundary solved by the
discrete cosine transform, Simchony et al. 1990, the whole rectangle) and
:func:`least_squares_integration` (sparse least squares over the mask only, orthographic or
perspective). Where the mask is not the full rectangle, the first two see zero gradients outside
it, so they suit masks with soft borders; the masked solver does not integrate across the
occluding contour and is the one to use on objects.

References
----------
.. [1] R. T. Frankot, R. Chellappa, "A method for enforcing integrability in shape from shading
   algorithms", IEEE TPAMI 10(4), 439-451, 1988.
.. [2] T. Simchony, R. Chellappa, M. Shao, "Direct analytical methods for solving Poisson
   equations in computer vision problems", IEEE TPAMI 12(5), 435-446, 1990.
.. [3] Y. Quéau, J.-D. Durou, J.-F. Aujol, "Normal integration: a survey", J. Math. Imaging
   Vis. 60, 576-593, 2018.
.. [4] J.-D. Durou, J.-F. Aujol, F. Courteille, "Integrating the normal field of a surface in
   the presence of discontinuities", EMMCVPR 2009.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from brdfkit._checks import as_float_array
from brdfkit.errors import ParameterError

MIN_NZ = 1e-2
"""Smallest ``|n_z|`` used in orthographic slopes ``-n_x / n_z``: caps a slope at 100 (89.4°)."""


def check_normals(normals: ArrayLike, mask: ArrayLike | None) -> tuple[np.ndarray, np.ndarray]:
    """Validate ``(H, W, 3)`` normals and an ``(H, W)`` mask with pixels; zero normals outside.

    Raises
    ------
    brdfkit.errors.ParameterError
        Normals not numeric or not (H, W, 3) with H, W >= 2, a mask of another shape or empty,
        or NaN or infinity in the normals inside the mask.
    """
    normals = as_float_array("normals", normals, finite=False)
    if normals.ndim != 3 or normals.shape[2] != 3:
        raise ParameterError(f"normals must have shape (H, W, 3), got shape {normals.shape}")
    if min(normals.shape[:2]) < 2:
        raise ParameterError(f"normals must be at least 2 x 2 pixels, got shape {normals.shape}")
    if mask is None:
        mask = np.ones(normals.shape[:2], dtype=bool)
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != normals.shape[:2]:
        raise ParameterError(f"mask must have shape {normals.shape[:2]}, got shape {mask.shape}")
    if not mask.any():
        raise ParameterError("mask has no pixels set: nothing to integrate")
    if not np.all(np.isfinite(normals[mask])):
        raise ParameterError("normals must be finite inside the mask")
    return np.where(mask[..., None], normals, 0.0), mask


def check_camera(camera: ArrayLike) -> np.ndarray:
    """Validate intrinsics ``K``: a finite (3, 3) matrix with positive focal lengths.

    Raises
    ------
    brdfkit.errors.ParameterError
        Naming what is wrong.
    """
    camera = as_float_array("camera", camera, finite=False)
    if camera.shape != (3, 3) or not np.all(np.isfinite(camera)):
        raise ParameterError(f"camera must be a finite (3, 3) intrinsics matrix K, got {camera!r}")
    if not (camera[0, 0] > 0 and camera[1, 1] > 0):
        raise ParameterError(
            "camera focal lengths K[0,0], K[1,1] must be positive, "
            f"got {camera[0, 0]}, {camera[1, 1]}"
        )
    return camera


def orthographic_gradients(
    normals: ArrayLike, mask: ArrayLike | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Depth gradients ``(d_u, d_v) = (n_x / n_z, -n_y / n_z)`` of an orthographic view.

    ``|n_z|`` is clamped to :data:`MIN_NZ` (sign kept); both gradients are 0 outside ``mask``.

    References
    ----------
    Y. Quéau, J.-D. Durou, J.-F. Aujol, J. Math. Imaging Vis. 60, 2018, §2.
    """
    normals, mask = check_normals(normals, mask)
    n_z = normals[..., 2]
    n_z = np.where(n_z < 0, -1.0, 1.0) * np.maximum(np.abs(n_z), MIN_NZ)
    d_u = np.where(mask, normals[..., 0] / n_z, 0.0)
    d_v = np.where(mask, -normals[..., 1] / n_z, 0.0)
    return d_u, d_v


def perspective_gradients(
    normals: ArrayLike, mask: ArrayLike | None, camera: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """Log-depth gradients of a perspective view with intrinsics ``camera`` (``K``).

    ``(\\partial_u, \\partial_v) \\log d = -(m_x / f_x, m_y / f_y) / (m . r)`` with the
    OpenCV-frame normal ``m = (n_x, -n_y, -n_z)`` and the pixel ray
    ``r = ((u - c_x)/f_x, (v - c_y)/f_y, 1)``; ``m . r`` is kept at least ``MIN_NZ |r|`` away
    from 0 (the ray grazing the surface), and both gradients are 0 outside ``mask``.

    References
    ----------
    J.-D. Durou, J.-F. Aujol, F. Courteille, EMMCVPR 2009; Y. Quéau et al., JMIV 60, 2018, §2.2.
    """
    normals, mask = check_normals(normals, mask)
    camera = check_camera(camera)
    f_x, f_y, c_x, c_y = camera[0, 0], camera[1, 1], camera[0, 2], camera[1, 2]
    rows, columns = np.indices(mask.shape, dtype=np.float64)
    r_x, r_y = (columns - c_x) / f_x, (rows - c_y) / f_y
    m_x, m_y, m_z = normals[..., 0], -normals[..., 1], -normals[..., 2]
    m_dot_r = m_x * r_x + m_y * r_y + m_z
    limit = MIN_NZ * np.sqrt(r_x**2 + r_y**2 + 1)
    m_dot_r = np.where(m_dot_r < 0, -1.0, 1.0) * np.maximum(np.abs(m_dot_r), limit)
    d_u = np.where(mask, -m_x / (f_x * m_dot_r), 0.0)
    d_v = np.where(mask, -m_y / (f_y * m_dot_r), 0.0)
    return d_u, d_v


def _finish(depth: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Orthographic depth shifted so the nearest mask pixel is at 0, NaN outside the mask."""
    return np.where(mask, depth - depth[mask].min(), np.nan)


def frankot_chellappa(normals: ArrayLike, mask: ArrayLike | None = None) -> np.ndarray:
    r"""Orthographic depth by Frankot–Chellappa: the integrable field nearest the gradients.

    With ``P, Q`` the Fourier transforms of the gradients ``d_u, d_v`` over the whole image
    (zero outside ``mask``) and ``\omega_u, \omega_v`` the angular frequencies,

    .. math:: \hat d = \frac{-i\,\omega_u P - i\,\omega_v Q}{\omega_u^2 + \omega_v^2},
              \quad \hat d(0, 0) = 0,

    the least-squares integration under periodic boundary conditions.

    Parameters
    ----------
    normals : (H, W, 3) unit normals (x right, y up, z towards the camera).
    mask : (H, W) bool, the pixels whose depth is returned; all when omitted.

    Returns
    -------
    (H, W) depth away from the camera in pixel units, 0 at the nearest mask pixel, NaN outside.

    References
    ----------
    R. T. Frankot, R. Chellappa, IEEE TPAMI 10(4), 1988.

    Examples
    --------
    A tilted plane has no periodic part: under periodic boundaries it integrates to nothing
    (:func:`poisson_dct` and :func:`least_squares_integration` recover it):

    >>> import numpy as np
    >>> plane = np.broadcast_to(np.array([0.5, 0.0, 1.0]) / np.sqrt(1.25), (3, 4, 3))
    >>> frankot_chellappa(plane).round(6).tolist()
    [[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]]
    """
    normals, mask = check_normals(normals, mask)
    d_u, d_v = orthographic_gradients(normals, mask)
    height, width = d_u.shape
    omega_u = 2 * np.pi * np.fft.fftfreq(width)[None, :]
    omega_v = 2 * np.pi * np.fft.fftfreq(height)[:, None]
    denominator = omega_u**2 + omega_v**2
    denominator[0, 0] = 1.0
    spectrum = (-1j * omega_u * np.fft.fft2(d_u) - 1j * omega_v * np.fft.fft2(d_v)) / denominator
    spectrum[0, 0] = 0.0
    return _finish(np.real(np.fft.ifft2(spectrum)), mask)


def poisson_dct(normals: ArrayLike, mask: ArrayLike | None = None) -> np.ndarray:
    r"""Orthographic depth from the Poisson equation with Neumann boundary, solved by the DCT.

    The least-squares depth satisfies :math:`\Delta d = \partial_u d_u + \partial_v d_v` inside
    the image and :math:`\nabla d \cdot \nu = (d_u, d_v) \cdot \nu` on its border. With the
    divergence by backward differences of the gradients and the 5-point Laplacian, the DCT-II
    diagonalises the Neumann problem:

    .. math:: \hat d_{kl} = \frac{\widehat{\operatorname{div}}_{kl}}
              {2\cos(\pi k / W) + 2\cos(\pi l / H) - 4}, \quad \hat d_{00} = 0.

    Parameters and returns as :func:`frankot_chellappa`.

    References
    ----------
    T. Simchony, R. Chellappa, M. Shao, IEEE TPAMI 12(5), 435-446, 1990.

    Examples
    --------
    A plane whose depth grows by half a pixel per column:

    >>> import numpy as np
    >>> plane = np.broadcast_to(np.array([0.5, 0.0, 1.0]) / np.sqrt(1.25), (3, 4, 3))
    >>> poisson_dct(plane).round(6).tolist()
    [[0.0, 0.5, 1.0, 1.5], [0.0, 0.5, 1.0, 1.5], [0.0, 0.5, 1.0, 1.5]]
    """
    import scipy.fft

    normals, mask = check_normals(normals, mask)
    d_u, d_v = orthographic_gradients(normals, mask)
    height, width = d_u.shape
    # Gradients at the half-pixel edges (mean of the two pixels), zero across the border.
    edge_u = np.zeros((height, width + 1))
    edge_u[:, 1:-1] = (d_u[:, 1:] + d_u[:, :-1]) / 2
    edge_v = np.zeros((height + 1, width))
    edge_v[1:-1] = (d_v[1:] + d_v[:-1]) / 2
    divergence = np.diff(edge_u, axis=1) + np.diff(edge_v, axis=0)
    k = np.arange(width)[None, :]
    l = np.arange(height)[:, None]
    eigenvalues = 2 * np.cos(np.pi * k / width) + 2 * np.cos(np.pi * l / height) - 4
    eigenvalues[0, 0] = 1.0
    spectrum = scipy.fft.dctn(divergence, type=2, norm="ortho") / eigenvalues
    spectrum[0, 0] = 0.0
    return _finish(scipy.fft.idctn(spectrum, type=2, norm="ortho"), mask)


def least_squares_integration(
    normals: ArrayLike, mask: ArrayLike | None = None, camera: ArrayLike | None = None
) -> np.ndarray:
    r"""Depth by sparse least squares over the mask, orthographic or perspective.

    Each pair of horizontally or vertically adjacent mask pixels ``p, q`` gives one equation
    ``z_q - z_p = (g_p + g_q) / 2`` (trapezoidal rule on the gradient ``g`` along that axis),
    with ``z`` the depth (orthographic) or the log-depth (perspective, ``camera`` given; see
    the module docstring). One extra equation per connected component of the mask fixes its
    constant; the normal equations are solved with ``scipy.sparse.linalg.spsolve``. Nothing is
    integrated across the occluding contour.

    Parameters
    ----------
    normals : (H, W, 3) unit normals (x right, y up, z towards the camera).
    mask : (H, W) bool; all pixels when omitted.
    camera : (3, 3) intrinsics ``K`` for a perspective view; orthographic when omitted.

    Returns
    -------
    (H, W) depth away from the camera, NaN outside the mask. Orthographic: pixel units, 0 at the
    nearest pixel of each component. Perspective: geometric mean 1 over each component.

    References
    ----------
    Y. Quéau, J.-D. Durou, J.-F. Aujol, J. Math. Imaging Vis. 60, 2018, §3 (discrete least
    squares); J.-D. Durou et al., EMMCVPR 2009 (perspective log-depth).

    Examples
    --------
    A plane whose depth grows by half a pixel per column, seen through a mask that leaves out
    one corner (NaN there):

    >>> import numpy as np
    >>> plane = np.broadcast_to(np.array([0.5, 0.0, 1.0]) / np.sqrt(1.25), (3, 4, 3))
    >>> mask = np.ones((3, 4), dtype=bool)
    >>> mask[0, 0] = False
    >>> least_squares_integration(plane, mask).round(6).tolist()
    [[nan, 0.5, 1.0, 1.5], [0.0, 0.5, 1.0, 1.5], [0.0, 0.5, 1.0, 1.5]]
    """
    import scipy.ndimage
    import scipy.sparse
    import scipy.sparse.linalg

    normals, mask = check_normals(normals, mask)
    if camera is None:
        d_u, d_v = orthographic_gradients(normals, mask)
    else:
        d_u, d_v = perspective_gradients(normals, mask, camera)
    index = np.full(mask.shape, -1)
    index[mask] = np.arange(mask.sum())
    blocks, targets = [], []
    for gradient, axis in ((d_u, 1), (d_v, 0)):
        first = mask & np.roll(mask, -1, axis=axis)
        if axis == 1:
            first[:, -1] = False
        else:
            first[-1] = False
        p = index[first]
        q = np.roll(index, -1, axis=axis)[first]
        blocks.append((p, q))
        targets.append((gradient[first] + np.roll(gradient, -1, axis=axis)[first]) / 2)
    labels, n_components = scipy.ndimage.label(mask)
    anchors = index[mask][np.unique(labels[mask], return_index=True)[1]]
    p = np.concatenate([b[0] for b in blocks])
    q = np.concatenate([b[1] for b in blocks])
    n_edges, n_pixels = len(p), int(mask.sum())
    rows = np.concatenate(
        [np.arange(n_edges), np.arange(n_edges), n_edges + np.arange(n_components)]
    )
    columns = np.concatenate([p, q, anchors])
    values = np.concatenate([-np.ones(n_edges), np.ones(n_edges), np.ones(n_components)])
    system = scipy.sparse.csr_matrix(
        (values, (rows, columns)), shape=(n_edges + n_components, n_pixels)
    )
    rhs = np.concatenate([*targets, np.zeros(n_components)])
    solution = scipy.sparse.linalg.spsolve((system.T @ system).tocsc(), system.T @ rhs)
    component = labels[mask] - 1
    if camera is None:
        nearest = np.full(n_components, np.inf)
        np.minimum.at(nearest, component, solution)
        depth = solution - nearest[component]
    else:
        solution -= (np.bincount(component, solution) / np.bincount(component))[component]
        depth = np.exp(solution)
    out = np.full(mask.shape, np.nan)
    out[mask] = depth
    return out


METHODS: dict[str, Callable[..., np.ndarray]] = {
    "least_squares": least_squares_integration,
    "poisson_dct": poisson_dct,
    "frankot_chellappa": frankot_chellappa,
}
"""The least-squares and Fourier integrators by name (with the bilateral ones,
:data:`brdfkit.vision.depth_from_normals.METHODS`: the choices of ``brdfkit integrate`` and
``brdfkit ps --integration``)."""
