"""Seeing reflectance: lobe plots, half/difference slices, albedo curves and sphere galleries.

Every plot has a ``*_data`` function that returns the numbers it draws (so tests can compare them
with closed forms) and a function that returns a :class:`matplotlib.figure.Figure`. They work on
any :class:`~brdfkit.brdf.base.BRDF`, measured ones included. Angles are radians at the API and
degrees on the axes.

References
----------
.. [1] B. Burley et al., Disney BRDF Explorer, 2012, https://github.com/wdas/brdf
.. [2] S. Rusinkiewicz, "A new change of variables for efficient BRDF representation", 1998.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from brdfkit._array import to_numpy
from brdfkit.brdf.base import BRDF
from brdfkit.geometry import from_half_diff, spherical_to_cartesian

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from brdfkit.light.base import Light


def _figure(**kwargs) -> Figure:
    from matplotlib.figure import Figure

    return Figure(**kwargs)


def model_label(brdf: BRDF, width: int | None = None) -> str:
    """A short label: the model's spec string, or the name of measured data (which has none).

    Examples
    --------
    >>> from brdfkit.brdf import Lambertian
    >>> model_label(Lambertian(rho=0.5))
    'lambertian(rho=0.5, allow_unphysical=False)'
    >>> model_label(Lambertian(rho=0.5), width=10)
    'lambertian'
    """
    try:
        text = brdf.to_spec()
    except ValueError:  # tabulated or measured data
        text = getattr(brdf, "name", "") or type(brdf).__name__
    return text if width is None else text[:width]


def _grey(values: np.ndarray) -> np.ndarray:
    """Channel mean of a ``(..., C)`` array (what single-curve plots show)."""
    return np.asarray(to_numpy(values), dtype=float).mean(axis=-1)


# --------------------------------------------------------------------------- lobes
def lobe_data(
    brdf: BRDF, theta_i: float, samples: int = 361, cosine: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """f(wi, wo) (or f·cos θo) for ``wo`` sweeping the plane of incidence.

    The light is at polar angle ``theta_i`` in the xz-plane on the −x side,
    wi = (−sin θi, 0, cos θi); ``wo`` runs over signed angles θ ∈ [−π/2, π/2] with
    wo = (sin θ, 0, cos θ), so the mirror direction is θ = +θi.

    Returns
    -------
    theta : (samples,) signed outgoing angles (radians).
    value : (samples,) grey value (channel mean).

    Examples
    --------
    A Lambertian lobe is flat, ρ/π (a half circle in :func:`lobe_plot` without the cosine):

    >>> import math
    >>> import numpy as np
    >>> from brdfkit.brdf import Lambertian
    >>> theta, value = lobe_data(Lambertian(rho=0.5), math.radians(30), samples=5)
    >>> np.degrees(theta).tolist(), (value * np.pi).round(4).tolist()
    ([-90.0, -45.0, 0.0, 45.0, 90.0], [0.5, 0.5, 0.5, 0.5, 0.5])
    """
    theta = np.linspace(-math.pi / 2, math.pi / 2, samples)
    wo = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=-1)
    wi = np.broadcast_to([-math.sin(theta_i), 0.0, math.cos(theta_i)], wo.shape)
    value = _grey(brdf.eval(wi, wo))
    if cosine:
        value = value * np.clip(np.cos(theta), 0, None)
    return theta, value


def lobe_plot(
    brdf: BRDF,
    thetas_i: Sequence[float] = tuple(math.radians(a) for a in (0, 30, 60)),
    *,
    cosine: bool = True,
    log: bool = False,
    title: str | None = None,
) -> Figure:
    """Polar lobe plot in the plane of incidence for several incidence angles.

    Examples
    --------
    >>> from brdfkit.brdf import parse
    >>> fig = lobe_plot(parse("lambertian(rho=0.3) + ggx(alpha=0.2)"))
    >>> fig.axes[0].name, len(fig.axes[0].get_lines())
    ('polar', 3)
    """
    fig = _figure(figsize=(4.2, 3.2), layout="constrained")
    ax = fig.add_subplot(projection="polar")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    ax.set_thetamin(-90)
    ax.set_thetamax(90)
    for theta_i in list(thetas_i):
        theta, value = lobe_data(brdf, theta_i, cosine=cosine)
        if log:
            value = np.log10(1 + value)
        ax.plot(theta, value, label=f"θi = {math.degrees(theta_i):.0f}°")
        ax.annotate(
            "",
            xy=(-theta_i, ax.get_rmax()),
            xytext=(0, 0),
            arrowprops={"arrowstyle": "<-", "alpha": 0.3},
        )
    ax.set_yticklabels([])
    # The half disc fills the middle half of the polar axes' square box: the legend goes just
    # below its flat side (y = 1/4 in axes coordinates), clear of the ±90° labels.
    ax.legend(
        loc="upper center",
        bbox_to_anchor=(0.5, 0.22),
        ncols=min(len(ax.get_lines()), 3) or 1,
        fontsize="x-small",
        frameon=False,
        handlelength=1.2,
        columnspacing=1.0,
    )
    quantity = "f·cos θo" if cosine else "f"
    ax.set_title(
        title or f"{quantity}{' (log₁₀(1+·))' if log else ''} in the plane of incidence",
        fontsize="small",
    )
    return fig


def lobe_3d(brdf: BRDF, theta_i: float = math.radians(45), resolution: int = 64) -> Figure:
    """3D lobe: the surface r(wo) = f(wi, wo)·cos θo over the hemisphere, light at ``theta_i``."""
    theta, phi = np.meshgrid(
        np.linspace(0, math.pi / 2, resolution), np.linspace(0, 2 * math.pi, 2 * resolution)
    )
    wo = spherical_to_cartesian(theta, phi)
    wi = np.broadcast_to([-math.sin(theta_i), 0.0, math.cos(theta_i)], wo.shape)
    r = _grey(brdf.eval(wi, wo)) * np.cos(theta)
    fig = _figure(figsize=(4, 4), layout="constrained")
    ax = fig.add_subplot(projection="3d")
    ax.plot_surface(*(wo * r[..., None]).transpose(2, 0, 1), cmap="viridis", linewidth=0)
    ax.set_title(f"f·cos θo, θi = {math.degrees(theta_i):.0f}°", fontsize="small")
    ax.set_box_aspect((1, 1, 0.6))
    return fig


# --------------------------------------------------------------------------- half/difference
def half_diff_data(
    brdf: BRDF, resolution: int = 90, phi_d: float = math.pi / 2
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """f over a θh × θd grid at fixed φd (BRDF Explorer's image slice; φh = 0).

    Returns ``theta_h`` (R,), ``theta_d`` (R,) and the grey values (R, R) indexed
    ``[theta_d, theta_h]``; pairs with a direction below the horizon are NaN.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import Lambertian
    >>> theta_h, theta_d, value = half_diff_data(Lambertian(rho=0.5), resolution=4)
    >>> np.degrees(theta_h).tolist()
    [11.25, 33.75, 56.25, 78.75]
    >>> value.shape, int(np.isnan(value).sum())  # at φd = 90° no pair dips below the horizon
    ((4, 4), 0)
    """
    theta_h = (np.arange(resolution) + 0.5) * (math.pi / 2 / resolution)
    theta_d = theta_h.copy()
    th, td = np.meshgrid(theta_h, theta_d)
    wi, wo = from_half_diff(th, np.zeros_like(th), td, np.full_like(th, phi_d))
    value = _grey(brdf.eval(wi, wo))
    below = (wi[..., 2] <= 0) | (wo[..., 2] <= 0)
    return theta_h, theta_d, np.where(below, np.nan, value)


def half_diff_plot(brdf: BRDF, resolution: int = 90, phi_d: float = math.pi / 2) -> Figure:
    """The θh × θd image slice (log scale) beside the θh and θd curves, as in BRDF Explorer."""
    from matplotlib.colors import LogNorm

    theta_h, theta_d, value = half_diff_data(brdf, resolution, phi_d)
    fig = _figure(figsize=(8, 3), layout="constrained")
    ax_img, ax_h, ax_d = fig.subplots(1, 3)
    positive = value[np.isfinite(value) & (value > 0)]
    norm = (
        LogNorm(vmin=max(positive.min(), positive.max() * 1e-4), vmax=positive.max())
        if positive.size
        else None
    )
    image = ax_img.imshow(
        value, origin="lower", extent=(0, 90, 0, 90), norm=norm, cmap="magma", aspect="equal"
    )
    fig.colorbar(image, ax=ax_img, shrink=0.8)
    ax_img.set(xlabel="θh (°)", ylabel="θd (°)", title=f"f at φd = {math.degrees(phi_d):.0f}°")
    for td_deg in (1, 30, 60, 80):
        row = min(int(td_deg / 90 * resolution), resolution - 1)
        ax_h.semilogy(np.degrees(theta_h), value[row], label=f"θd = {td_deg}°")
    ax_h.set(xlabel="θh (°)", ylabel="f", title="θh curves")
    ax_h.legend(fontsize="x-small", frameon=False)
    for th_deg in (0, 10, 30, 60):
        col = min(int(th_deg / 90 * resolution), resolution - 1)
        ax_d.semilogy(np.degrees(theta_d), value[:, col], label=f"θh = {th_deg}°")
    ax_d.set(xlabel="θd (°)", title="θd curves")
    ax_d.legend(fontsize="x-small", frameon=False)
    return fig


# --------------------------------------------------------------------------- albedo
def albedo_data(
    brdf: BRDF, angles: int = 30, samples: int = 4096
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Directional albedo ρ(θo) (grey) with its Monte Carlo standard error.

    Examples
    --------
    A Lambertian surface reflects ρ at every angle; sampled by its cosine, with no error:

    >>> from brdfkit.brdf import Lambertian
    >>> theta, rho, stderr = albedo_data(Lambertian(rho=0.5), angles=3, samples=256)
    >>> rho.round(12).tolist(), stderr.tolist()
    ([0.5, 0.5, 0.5], [0.0, 0.0, 0.0])
    """
    theta = np.linspace(0, math.radians(89), angles)
    wo = spherical_to_cartesian(theta, np.zeros_like(theta))
    mean, stderr = brdf.albedo_estimate(wo, samples=samples)
    return theta, _grey(mean), _grey(stderr)


def albedo_plot(
    brdfs: BRDF | Sequence[BRDF], labels: Sequence[str] | None = None, **kwargs
) -> Figure:
    """ρ(θo) curves with the energy-conservation line at 1 (shaded ± 3 standard errors)."""
    models = [brdfs] if isinstance(brdfs, BRDF) else list(brdfs)
    labels = list(labels) if labels is not None else [model_label(m, 40) for m in models]
    fig = _figure(figsize=(4.2, 3), layout="constrained")
    ax = fig.add_subplot()
    for model, label in zip(models, labels, strict=True):
        theta, rho, err = albedo_data(model, **kwargs)
        (line,) = ax.plot(np.degrees(theta), rho, label=label)
        ax.fill_between(
            np.degrees(theta), rho - 3 * err, rho + 3 * err, color=line.get_color(), alpha=0.2
        )
    ax.axhline(1.0, color="k", linestyle="--", linewidth=1, label="energy conservation")
    ax.set(xlabel="θo (°)", ylabel="ρ(θo)", xlim=(0, 90), ylim=(0, max(1.1, ax.get_ylim()[1])))
    ax.legend(fontsize="x-small", frameon=False)
    return fig


# --------------------------------------------------------------------------- spheres
def sphere_images(
    brdfs: Sequence[BRDF],
    lights: Light | Sequence[Light],
    resolution: int = 128,
    samples: int = 64,
    exposure: float | None = None,
) -> list[np.ndarray]:
    """Render one sphere per model and encode them for display as 8-bit sRGB, ``(R, R, 3)``.

    With ``exposure=None`` one exposure serves the whole row (so that spheres stay comparable):
    the 99th percentile of luminance over all spheres maps to white; otherwise ``exposure`` is
    in stops.
    """
    from brdfkit.render.shading import render_sphere

    images = [
        render_sphere(model, lights, resolution=resolution, samples=samples) for model in brdfs
    ]
    return encode_spheres(images, exposure)


def encode_spheres(images: Sequence[np.ndarray], exposure: float | None = None) -> list[np.ndarray]:
    """Linear sphere images ``(R, R, C)`` as 8-bit sRGB ``(R, R, 3)``, one exposure for the
    row as in :func:`sphere_images`.

    Examples
    --------
    >>> import numpy as np
    >>> dim, bright = encode_spheres([np.full((4, 4, 1), 0.25), np.full((4, 4, 3), 0.5)])
    >>> dim.shape, dim.dtype
    ((4, 4, 3), dtype('uint8'))
    >>> dim[0, 0].tolist(), bright[0, 0].tolist()  # the brighter maps to white
    ([188, 188, 188], [255, 255, 255])
    """
    from brdfkit.io import luminance, srgb_encode, tonemap

    images = [np.repeat(im, 3, axis=-1) if im.shape[-1] == 1 else im[..., :3] for im in images]
    if exposure is None:
        lum = np.concatenate([np.asarray(luminance(im)).ravel() for im in images])
        lum = lum[lum > 0]
        exposure = -math.log2(np.percentile(lum, 99)) if lum.size else 0.0
    return [
        (np.clip(np.asarray(srgb_encode(tonemap(im, exposure=exposure))), 0, 1) * 255 + 0.5).astype(
            np.uint8
        )
        for im in images
    ]


def sphere_gallery(
    brdfs: Sequence[BRDF],
    lights: Light | Sequence[Light],
    labels: Sequence[str] | None = None,
    resolution: int = 128,
    samples: int = 64,
    exposure: float | None = None,
) -> Figure:
    """A row of spheres, e.g. across one parameter (roughness, exponent, σ, η)."""
    models = list(brdfs)
    labels = list(labels) if labels is not None else [model_label(m, 30) for m in models]
    fig = _figure(figsize=(1.6 * len(models), 1.9), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, len(models)))
    images = sphere_images(models, lights, resolution, samples, exposure)
    for ax, image, label in zip(axes, images, labels, strict=True):
        ax.imshow(image)
        # A spec wider than its sphere wraps at its spaces rather than running into the next.
        lines = textwrap.wrap(label, 24, break_long_words=False, break_on_hyphens=False)
        ax.set_title("\n".join(lines), fontsize="x-small")
        ax.axis("off")
    return fig


def save(fig: Figure, path, dpi: int = 110) -> None:
    """Save ``fig`` to ``path`` (PNG/SVG/PDF by extension), atomically.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from brdfkit.brdf import Lambertian
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     save(lobe_plot(Lambertian(rho=0.5)), Path(folder) / "lobe.png", dpi=30)
    ...     print(sorted(p.name for p in Path(folder).iterdir()))
    ['lobe.png']
    """
    from brdfkit.io import atomic_write

    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=dpi))


__all__ = [
    "albedo_data",
    "albedo_plot",
    "encode_spheres",
    "half_diff_data",
    "half_diff_plot",
    "lobe_3d",
    "lobe_data",
    "lobe_plot",
    "model_label",
    "save",
    "sphere_gallery",
    "sphere_images",
]
