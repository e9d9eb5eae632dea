"""Plots: their data against closed forms, and that every figure draws."""

from __future__ import annotations

import math

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from brdfkit import plot
from brdfkit.brdf import Lambertian, parse
from brdfkit.light import DirectionalLight


def test_lobe_data_of_lambertian_is_rho_over_pi_times_cosine():
    theta, value = plot.lobe_data(Lambertian(0.6), math.radians(30), cosine=True)
    np.testing.assert_allclose(value, 0.6 / math.pi * np.clip(np.cos(theta), 0, None), atol=1e-12)


def test_lobe_data_peaks_at_the_mirror_direction_for_modified_phong():
    theta_i = math.radians(40)
    theta, value = plot.lobe_data(parse("modified_phong(kd=0, ks=1, n=200)"), theta_i)
    assert abs(theta[np.argmax(value)] - theta_i) < math.radians(1)
    peak = (200 + 2) / (2 * math.pi)  # ρs (n+2)/(2π) cos⁰ at the mirror direction
    assert abs(value.max() - peak) / peak < 1e-3


def test_half_diff_slice_of_lambertian_is_flat_and_albedo_curve_is_rho():
    _, _, value = plot.half_diff_data(Lambertian(0.5), resolution=30)
    finite = value[np.isfinite(value)]
    np.testing.assert_allclose(finite, 0.5 / math.pi, rtol=1e-12)
    _, rho, err = plot.albedo_data(Lambertian(0.5), angles=5)
    np.testing.assert_allclose(rho, 0.5, rtol=1e-12)
    assert np.all(err == 0)


def test_rendered_lambertian_sphere_matches_closed_form_through_the_display_pipeline():
    d = np.array([1.0, 0.3, 0.4])
    d /= np.linalg.norm(d)
    (image,) = plot.sphere_images([Lambertian(1.0)], DirectionalLight(d, math.pi), 64, exposure=0.0)
    from brdfkit.io import srgb_decode
    from brdfkit.render import Sphere, gbuffer

    g = gbuffer(Sphere(), None, 64)
    expected = np.clip(g.normals @ d, 0, 1) * g.mask  # ρ/π · π · cos = cos
    # 8-bit quantisation: half a code times the sRGB decode's largest slope (2.4/1.055).
    quantisation = 0.5 / 255 * 2.4 / 1.055
    np.testing.assert_allclose(srgb_decode(image[..., 0] / 255.0), expected, atol=quantisation)


@pytest.mark.parametrize(
    "draw",
    [
        lambda m: plot.lobe_plot(m, [0.0, 0.5], log=True),
        lambda m: plot.lobe_3d(m, 0.5, resolution=16),
        lambda m: plot.half_diff_plot(m, resolution=20),
        lambda m: plot.albedo_plot([m, Lambertian(0.3)], samples=64, angles=4),
        lambda m: plot.sphere_gallery([m], DirectionalLight((1, 0, 0)), resolution=16, samples=4),
    ],
    ids=["lobe", "lobe3d", "half-diff", "albedo", "spheres"],
)
def test_every_figure_draws(draw, tmp_path):
    fig = draw(parse("lambertian(albedo=0.3) + blinn_phong(n=30)"))
    plot.save(fig, tmp_path / "f.png")
    assert (tmp_path / "f.png").stat().st_size > 1000


def _text_boxes(fig) -> list[tuple[str, object]]:
    """(text, window extent) of every piece of text the drawn figure shows: titles, labels,
    the tick labels inside the axes' view, and each legend as one box (its entries inside)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.text import Text

    FigureCanvasAgg(fig).draw()
    renderer = fig.canvas.get_renderer()
    hidden = set()
    legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes if ax.get_legend())]
    for legend in legends:
        hidden |= {id(t) for t in legend.findobj(Text)}
    for ax in fig.axes:
        if not (ax._axis3don if ax.name == "3d" else ax.axison):  # images: only titles drawn
            titles = (ax.title, ax._left_title, ax._right_title)
            hidden |= {id(t) for t in ax.findobj(Text) if t not in titles}
            continue
        for axis in ax._axis_map.values():
            lo, hi = sorted(axis.get_view_interval())
            slack = 1e-9 * max(1.0, hi - lo)
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                if not lo - slack <= tick.get_loc() <= hi + slack:  # not drawn
                    hidden |= {id(tick.label1), id(tick.label2)}
    boxes = [
        (t.get_text(), t.get_window_extent(renderer))
        for t in fig.findobj(Text)
        if id(t) not in hidden and t.get_visible() and t.get_text().strip()
    ]
    boxes += [("legend", legend.get_window_extent(renderer)) for legend in legends]
    return [(text, box) for text, box in boxes if box.width > 0 and box.height > 0]


def _assert_text_is_clear(fig) -> None:
    boxes = _text_boxes(fig)
    assert len(boxes) >= 2
    clashes = [
        (a, b) for i, (a, box) in enumerate(boxes) for b, other in boxes[i + 1 :]
        if box.overlaps(other)
    ]  # fmt: skip
    assert clashes == [], f"overlapping text: {clashes}"
    width, height = fig.canvas.get_width_height()
    cut = [t for t, b in boxes if b.x0 < -1 or b.y0 < -1 or b.x1 > width + 1 or b.y1 > height + 1]
    assert cut == [], f"text cut off at the figure's edge: {cut}"


_LONG_SPECS = ("ward(alpha_x=0.3, normalization='ward')", "ward(alpha_x=0.3)")


@pytest.mark.parametrize(
    "draw",
    [
        lambda m: plot.lobe_plot(m, [math.radians(a) for a in (0, 30, 60)]),  # the atlas's
        lambda m: plot.lobe_plot(m, [math.radians(a) for a in (0, 20, 40, 60, 80)], log=True),
        lambda m: plot.lobe_3d(m, 0.5, resolution=16),
        lambda m: plot.half_diff_plot(m, resolution=20),
        lambda m: plot.albedo_plot([m] * 4, labels=["#1", "#2", "#3", "#4"], samples=64, angles=4),
        lambda m: plot.albedo_plot(
            [parse(s) for s in _LONG_SPECS], labels=list(_LONG_SPECS), samples=64, angles=4
        ),
        lambda m: plot.sphere_gallery(
            [parse(s) for s in _LONG_SPECS],
            DirectionalLight((1, 0, 1)),
            labels=list(_LONG_SPECS),
            resolution=16,
            samples=2,
        ),
    ],
    ids=["lobe", "lobe-5-angles", "lobe3d", "half-diff", "albedo", "albedo-specs", "spheres"],
)
def test_no_text_overlaps_or_is_cut_off(draw):
    _assert_text_is_clear(draw(parse("lambertian(albedo=0.3) + blinn_phong(n=30)")))


def test_overlap_check_sees_the_old_lobe_legend_over_the_minus_90_label():
    fig = plot.lobe_plot(Lambertian(0.5))
    fig.axes[0].legend(loc="upper left", bbox_to_anchor=(-0.25, 0.35), fontsize="x-small")
    with pytest.raises(AssertionError, match="overlapping text"):
        _assert_text_is_clear(fig)


def test_lobe_plot_default_angles_on_every_call():
    # the default incidence angles were a generator, spent by the first call: later calls
    # without ``thetas_i`` drew no curves
    for _ in range(2):
        assert len(plot.lobe_plot(Lambertian(0.5)).axes[0].get_lines()) == 3
