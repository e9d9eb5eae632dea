r"""Meshes that ship with brdfkit, generated from their formulas on first use (no files, no
licence to carry): objects to judge a material on, each over a ground plane, in Mitsuba 3's
world frame (+y up, ground at y = 0).

- ``knot``: the (2, 3) torus knot (a trefoil) as a tube of radius 0.14,

  .. math:: c(t) = s\,\big((2 + \cos 3t)\cos 2t,\; \sin 3t,\; (2 + \cos 3t)\sin 2t\big),

  its normals exact (from the tube's centre line, the frame :math:`N = T \times \hat y`
  normalised, :math:`B = T \times N`, periodic since the curve's xz-speed never vanishes):
  curvature of every sign, self-shadowing loops, a cast shadow on the ground.
- ``shaderball``: a surface of revolution in the manner of material-preview "shader balls":
  a pedestal, a concave neck, a ball with a concave cup cut into its top; normals exact for
  each piece (sharp edges where pieces meet): convex, concave and saddle-shaped highlights,
  attached and cast shadows, interreflection-free concavities that direct lighting shows dark.

A name is given as ``bundled:NAME`` wherever a mesh file is (``brdfkit render bundled:knot``,
the explorer's lit-object view): :func:`load_mesh`.

References
----------
.. [1] T. Duff et al., "Building an orthonormal basis, revisited", JCGT 6(1), 2017 (a frame
       without a preferred axis; here the knot's own axis serves).
.. [2] W. Jakob et al., Mitsuba 3's material-preview scenes (the "matpreview" shader ball).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from brdfkit.errors import ParameterError
from brdfkit.render.mesh import MESH_SUFFIXES, MeshScene

BUNDLED_PREFIX = "bundled:"
"""How a bundled mesh is named where a mesh file may be given."""

GROUND_HALF_WIDTH = 3.0
"""The ground square spans [−3, 3] in x and z at y = 0."""


def knot(sections: int = 192, ring: int = 16, scale: float = 0.3, radius: float = 0.14) -> Any:
    """The trefoil knot tube over the ground: a ``trimesh.Trimesh`` of
    2 · ``sections`` · ``ring`` + 2 triangles, its lowest point 0.1 above the ground.

    Examples
    --------
    >>> mesh = knot(sections=24, ring=6)
    >>> len(mesh.faces), round(float(mesh.vertices[:-4, 1].min()), 6)
    (290, 0.1)
    """
    t = np.linspace(0.0, 2 * np.pi, sections, endpoint=False)
    big = 2 + np.cos(3 * t)
    centre = scale * np.stack([big * np.cos(2 * t), np.sin(3 * t), big * np.sin(2 * t)], -1)
    tangent = _unit(
        np.stack(
            [
                -3 * np.sin(3 * t) * np.cos(2 * t) - 2 * big * np.sin(2 * t),
                3 * np.cos(3 * t),
                -3 * np.sin(3 * t) * np.sin(2 * t) + 2 * big * np.cos(2 * t),
            ],
            -1,
        )
    )
    n = _unit(np.cross(tangent, [0.0, 1.0, 0.0]))
    b = np.cross(tangent, n)
    s = np.linspace(0.0, 2 * np.pi, ring, endpoint=False)
    normals = np.cos(s)[None, :, None] * n[:, None] + np.sin(s)[None, :, None] * b[:, None]
    vertices = centre[:, None] + radius * normals
    vertices[..., 1] += 0.1 - vertices[..., 1].min()
    faces = _grid_faces(sections, ring, wrap_rows=True)
    return _with_ground(vertices.reshape(-1, 3), faces, normals.reshape(-1, 3))


def shaderball(sections: int = 96) -> Any:
    """The shader ball over the ground: a ``trimesh.Trimesh`` (pedestal of radius 0.7, ball of
    radius 0.5 centred 0.95 above the ground, a cup 0.2 deep in its top).

    Examples
    --------
    >>> mesh = shaderball(sections=12)
    >>> mesh.bounds.round(3).tolist()
    [[-3.0, 0.0, -3.0], [3.0, 1.333, 3.0]]
    """
    pieces = [_revolve(points, normals, sections) for points, normals in _shaderball_profile()]
    vertices = np.concatenate([v for v, _, _ in pieces])
    normals = np.concatenate([n for _, _, n in pieces])
    offsets = np.cumsum([0] + [len(v) for v, _, _ in pieces[:-1]])
    faces = np.concatenate([f + o for (_, f, _), o in zip(pieces, offsets, strict=True)])
    return _with_ground(vertices, faces, normals)


BUNDLED_MESHES: dict[str, Callable[[], Any]] = {"knot": knot, "shaderball": shaderball}
"""The bundled meshes by name: each a function returning a ``trimesh.Trimesh``."""


@functools.cache
def bundled_scene(name: str) -> MeshScene:
    """The :class:`~brdfkit.render.mesh.MeshScene` of a bundled mesh (made once per process).

    Raises :class:`~brdfkit.errors.ParameterError` naming the bundled meshes for another name.
    """
    if name not in BUNDLED_MESHES:
        raise ParameterError(
            f"bundled mesh must be one of {', '.join(sorted(BUNDLED_MESHES))}; got {name!r}"
        )
    return MeshScene.from_trimesh(BUNDLED_MESHES[name]())


def object_bounds(name: str) -> np.ndarray:
    """The bounding box ``(2, 3)`` (least, greatest corner) of a bundled mesh's object, its
    ground left out: what a camera frames.

    Examples
    --------
    >>> object_bounds("shaderball").round(3).tolist()
    [[-0.7, 0.0, -0.7], [0.7, 1.333, 0.7]]
    """
    vertices = bundled_scene(name).vertices[:-4]  # the ground's four corners come last
    return np.stack([vertices.min(axis=0), vertices.max(axis=0)])


def is_mesh_source(source: str) -> bool:
    """Whether ``source`` names a mesh: ``bundled:NAME`` or a path with a mesh suffix."""
    return source.startswith(BUNDLED_PREFIX) or Path(source).suffix.lower() in MESH_SUFFIXES


def load_mesh(source: str | Path) -> MeshScene:
    """The scene of ``bundled:NAME`` (:data:`BUNDLED_MESHES`) or of a mesh file
    (:meth:`~brdfkit.render.mesh.MeshScene.from_file`).

    Examples
    --------
    >>> scene = load_mesh("bundled:knot")
    >>> len(scene.faces), bool(np.allclose(np.linalg.norm(scene.vertex_normals, axis=1), 1))
    (6146, True)
    >>> load_mesh("bundled:teapot")
    Traceback (most recent call last):
    ...
    brdfkit.errors.ParameterError: bundled mesh must be one of knot, shaderball; got 'teapot'
    """
    text = str(source)
    if text.startswith(BUNDLED_PREFIX):
        return bundled_scene(text[len(BUNDLED_PREFIX) :])
    return MeshScene.from_file(source)


def _shaderball_profile() -> list[tuple[np.ndarray, np.ndarray]]:
    """The profile pieces ``(points (K, 2), normals (K, 2))`` in (radius, height), each a
    smooth piece of the surface of revolution."""
    pieces = []
    # pedestal: side, then top annulus
    pieces.append((np.array([[0.7, 0.0], [0.7, 0.12]]), np.array([[1.0, 0.0], [1.0, 0.0]])))
    pieces.append((np.array([[0.7, 0.12], [0.3, 0.12]]), np.array([[0.0, 1.0], [0.0, 1.0]])))
    # concave neck r(y) = 0.18 + 0.12 (2s − 1)², s = (y − 0.12) / 0.43: normal ∝ (1, −r'(y))
    s = np.linspace(0.0, 1.0, 12)
    y = 0.12 + 0.43 * s
    r = 0.18 + 0.12 * (2 * s - 1) ** 2
    slope = 0.12 * 2 * (2 * s - 1) * 2 / 0.43
    pieces.append((np.stack([r, y], -1), _unit(np.stack([np.ones_like(s), -slope], -1))))
    # ball: centre (0, 0.95), radius 0.5, from the neck (cos θ = −0.8) up to the rim (θ = 40°)
    theta = np.linspace(np.arccos(-0.8), np.radians(40.0), 32)
    ball = np.stack([np.sin(theta), np.cos(theta)], -1)
    pieces.append((np.array([0.0, 0.95]) + 0.5 * ball, ball))
    # the cup: a sphere of radius ρ centred above, through the rim and 0.2 below it
    rim = np.array([0.5 * np.sin(np.radians(40.0)), 0.95 + 0.5 * np.cos(np.radians(40.0))])
    bottom = rim[1] - 0.2
    rho = (rim[0] ** 2 + (rim[1] - bottom) ** 2) / (2 * (rim[1] - bottom))
    centre = np.array([0.0, bottom + rho])
    angle = np.linspace(np.arctan2(rim[0], centre[1] - rim[1]), 0.0, 16)
    points = centre + rho * np.stack([np.sin(angle), -np.cos(angle)], -1)
    pieces.append((points, _unit(centre - points)))
    return pieces


def _revolve(points: np.ndarray, normals: np.ndarray, sections: int):
    """A profile ``(K, 2)`` in (radius, height) with its normals turned about +y in
    ``sections`` steps: vertices, faces (wound along the normals, none of zero area) and
    normals."""
    phi = np.linspace(0.0, 2 * np.pi, sections, endpoint=False)
    c, s = np.cos(phi)[None, :], np.sin(phi)[None, :]

    def turn(p: np.ndarray) -> np.ndarray:
        r, h = p[:, :1], p[:, 1:]
        return np.stack([r * c, np.broadcast_to(h, (len(p), sections)), r * s], -1)

    vertices, vertex_normals = turn(points).reshape(-1, 3), turn(normals).reshape(-1, 3)
    faces = _grid_faces(len(points), sections, wrap_rows=False)
    corners = vertices[faces]
    area = np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=-1
    )
    faces = faces[area > 0]  # none of zero area where the profile meets the axis
    return vertices, _oriented(faces, vertices, vertex_normals), vertex_normals


def _grid_faces(rows: int, columns: int, wrap_rows: bool) -> np.ndarray:
    """Two triangles per cell of a ``rows`` × ``columns`` vertex grid, columns wrapping
    (and rows too with ``wrap_rows``)."""
    i, j = np.meshgrid(np.arange(rows if wrap_rows else rows - 1), np.arange(columns),
                       indexing="ij")  # fmt: skip
    a = i * columns + j
    b = i * columns + (j + 1) % columns
    c = ((i + 1) % rows) * columns + (j + 1) % columns
    d = ((i + 1) % rows) * columns + j
    return np.concatenate([np.stack([a, b, c], -1), np.stack([a, c, d], -1)]).reshape(-1, 3)


def _oriented(faces: np.ndarray, vertices: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """``faces`` with each triangle wound so that its geometric normal agrees with its
    vertices' mean normal."""
    corners = vertices[faces]
    geometric = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    flip = np.sum(geometric * normals[faces].sum(axis=1), axis=-1) < 0
    return np.where(flip[:, None], faces[:, ::-1], faces)


def _with_ground(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray) -> Any:
    """The object and the ground square (normal +y) as one ``trimesh.Trimesh``, the object's
    faces wound along its normals."""
    import trimesh

    w = GROUND_HALF_WIDTH
    ground = np.array([[-w, 0.0, -w], [w, 0.0, -w], [w, 0.0, w], [-w, 0.0, w]])
    n = len(vertices)
    return trimesh.Trimesh(
        np.concatenate([vertices, ground]),
        np.concatenate(
            [_oriented(faces, vertices, normals), [[n, n + 2, n + 1], [n, n + 3, n + 2]]]
        ),
        vertex_normals=np.concatenate([normals, np.tile([0.0, 1.0, 0.0], (4, 1))]),
        process=False,
    )


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


__all__ = [
    "BUNDLED_MESHES",
    "BUNDLED_PREFIX",
    "GROUND_HALF_WIDTH",
    "bundled_scene",
    "is_mesh_source",
    "knot",
    "load_mesh",
    "object_bounds",
    "shaderball",
]
