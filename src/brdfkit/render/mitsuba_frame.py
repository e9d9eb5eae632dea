r"""Scenes in Mitsuba 3's world frame: its look-at sensor and its environment-map orientation.

A mesh scene (:mod:`brdfkit.render.mesh`) is given as a Mitsuba 3 scene would be, so that one
converts to the other one to one:

- **Camera.** ``look_at(origin, target, up)`` with the film's right along
  :math:`\mathrm{dir} \times \mathrm{up}` and its top along ``up`` (Mitsuba's
  ``Transform4f.look_at`` and its sensors' flipped film axes, the same as
  :meth:`brdfkit.render.Camera.look_at`); ``fov`` in degrees across the image's *width*
  (Mitsuba's default ``fov_axis="x"``); without a fov, an orthographic view spanning
  [−1, 1] across the width (Mitsuba's ``orthographic`` sensor without scaling).
- **Environment maps.** Mitsuba's ``envmap`` reads texel :math:`(u, v) = (\phi/2\pi,
  \theta/\pi)` as :math:`(\sin\theta\sin\phi, \cos\theta, -\sin\theta\cos\phi)` (pole +y);
  brdfkit's maps read it as :math:`(\sin\theta\cos\phi, \sin\theta\sin\phi, \cos\theta)` (pole
  +z), then their ``rotation``. :data:`MITSUBA_ENVMAP_ROTATION` is the rotation that makes a
  brdfkit map light the world as Mitsuba's ``envmap`` with an identity ``to_world``.
- **Skies** (:class:`~brdfkit.light.SunSky`, :class:`~brdfkit.light.UniformSky`: zenith +z)
  are turned by the same rotation (:class:`RotatedLight`), so that their zenith is +y, as
  the maps' poles: a sky's ``sun_direction`` :math:`(x, y, z)` lies at :math:`P(x, y, z) =
  (y, z, -x)` in the world.
- **Directional lights** are given, as everywhere in brdfkit, by the direction towards the
  light: minus Mitsuba's ``direction``.

References
----------
.. [1] W. Jakob, S. Speierer, N. Roussel et al., "Mitsuba 3 renderer", 2022,
       https://mitsuba-renderer.org (plugins ``perspective``, ``orthographic``, ``envmap``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from brdfkit.errors import ParameterError
from brdfkit.light.analytic import UniformSky
from brdfkit.light.base import Light, LightSample
from brdfkit.light.environment import EnvironmentMap
from brdfkit.light.sunsky import SunSky
from brdfkit.render.scene import Camera

MITSUBA_ENVMAP_ROTATION = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])
r"""P: brdfkit map directions (pole +z) to Mitsuba ``envmap``-local ones (pole +y),
:math:`d_{mi} = P d`; as an :class:`~brdfkit.light.EnvironmentMap`'s ``rotation`` it orients the
map as Mitsuba's."""


def look_at_camera(
    origin: Any,
    target: Any,
    up: Any,
    fov: float | None = None,
    size: tuple[int, int] = (256, 256),
) -> Camera:
    """A camera as Mitsuba's sensor with ``to_world=look_at(origin, target, up)``.

    Parameters
    ----------
    origin, target, up : world points and the up vector (3 numbers each).
    fov : horizontal field of view in degrees (perspective), or ``None`` (orthographic,
        [−1, 1] across the width).
    size : the image's ``(height, width)`` in pixels (:class:`~brdfkit.render.Camera` spans
        its larger side; this converts the width's span to it).

    Examples
    --------
    A 40° camera on a portrait image spans more than 40° across its height:

    >>> camera = look_at_camera((0, 1, 5), (0, 1, 0), (0, 1, 0), fov=40, size=(200, 100))
    >>> round(math.degrees(camera.fov), 2), camera.rotation[:, 0].tolist()  # right: +x
    (72.1, [1.0, 0.0, 0.0])
    >>> look_at_camera((0, 0, 5), (0, 0, 0), (0, 1, 0), size=(48, 64)).extent
    2.0
    """
    height, width = size
    stretch = max(height, width) / width
    if fov is None:
        return Camera.look_at(origin, target, up, kind="orthographic", extent=2.0 * stretch)
    if not 0 < fov < 180:
        raise ParameterError(f"fov must be in (0, 180) degrees; got {fov}")
    half = math.atan(math.tan(math.radians(fov) / 2) * stretch)
    return Camera.look_at(origin, target, up, kind="perspective", fov=2 * half)


@dataclass(frozen=True, eq=False)
class RotatedLight(Light):
    r"""A distant light turned by the rotation ``rotation`` R: its radiance towards the world
    direction :math:`\omega` is ``light``'s towards :math:`R^\top\omega`, its samples
    ``light``'s turned by R, their density unchanged (a rotation keeps solid angle).

    Examples
    --------
    A uniform sky over +z turned so that its zenith is +y:

    >>> sky = RotatedLight(UniformSky(2.0), MITSUBA_ENVMAP_ROTATION)
    >>> up_and_z = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    >>> sky.incident_radiance(np.zeros(3), up_and_z).tolist()
    [[2.0], [0.0]]
    >>> bool(sky.sample(np.zeros(3), np.array([0.3, 0.6])).wi[1] > 0)
    True
    """

    light: Light
    rotation: Any

    def __post_init__(self) -> None:
        r = np.asarray(self.rotation, dtype=np.float64)
        if r.shape != (3, 3) or not np.allclose(r @ r.T, np.eye(3), atol=1e-9):
            raise ParameterError(f"rotation must be an orthonormal 3×3 matrix; got {r!r}")
        if self.light.delta:
            raise ParameterError("RotatedLight turns distant extended lights, not delta lights")
        object.__setattr__(self, "rotation", r)
        object.__setattr__(self, "channels", self.light.channels)

    def incident_radiance(self, points: Any, wi: Any) -> Any:
        return self.light.incident_radiance(self._inner(points), self._inner(wi))

    def pdf(self, points: Any, wi: Any) -> Any:
        return self.light.pdf(self._inner(points), self._inner(wi))

    def sample(self, points: Any, u: Any) -> LightSample:
        sample = self.light.sample(self._inner(points), u)
        return dataclasses.replace(sample, wi=sample.wi @ self.rotation.T)

    def _inner(self, v: Any) -> Any:
        r"""World vectors in the inner light's frame, :math:`R^\top v` (rows: ``v @ R``)."""
        return np.asarray(v) @ self.rotation


def mitsuba_oriented(light: Light) -> Light:
    """``light`` oriented in Mitsuba's world frame: an environment map turned by
    :data:`MITSUBA_ENVMAP_ROTATION` (after its own rotation), a sky (sun and sky, uniform
    sky) by the same rotation (:class:`RotatedLight`); other lights unchanged.

    Examples
    --------
    The map's zenith (row 0) lights the world from +y, as in Mitsuba:

    >>> image = np.zeros((4, 8, 1))
    >>> image[0] = 1.0
    >>> env = mitsuba_oriented(EnvironmentMap(image))
    >>> env.incident_radiance(np.zeros(3), np.array([0.0, 1.0, 0.0])).tolist()
    [1.0]
    """
    if isinstance(light, SunSky | UniformSky):
        return RotatedLight(light, MITSUBA_ENVMAP_ROTATION)
    if not isinstance(light, EnvironmentMap):
        return light
    return dataclasses.replace(light, rotation=MITSUBA_ENVMAP_ROTATION @ light.rotation)


__all__ = ["MITSUBA_ENVMAP_ROTATION", "RotatedLight", "look_at_camera", "mitsuba_oriented"]
