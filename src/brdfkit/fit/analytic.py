r"""Fitting analytic BRDF models to measured data.

Any registered model, or a sum of them (``"lambertian + cook_torrance"``), is fitted to any
measured BRDF (:mod:`brdfkit.measured`) or set of samples by nonlinear least squares
(:func:`scipy.optimize.least_squares`, trust-region reflective with bounds, finite-difference
Jacobian, float64; the model evaluated by its :mod:`brdfkit.compiled` kernel where one
serves all its parameter values, by NumPy otherwise).
Objectives, with :math:`c_i = \cos\theta_i` and the measured/model values :math:`f, \hat f`
per sample and channel:

- ``"cosine"`` — Ngan, Durand & Matusik (2005): :math:`r = (\hat f - f)\,c_i`, i.e. the
  cosine-weighted L2 error :math:`E = \sqrt{\tfrac1N\sum (\hat f c_i - f c_i)^2}`;
- ``"log"`` — a compressed relative error (Löw et al. 2012):
  :math:`r = \ln(1 + \hat f c_i / s) - \ln(1 + f c_i / s)`, at the data's own level :math:`s`
  (:func:`log_scale`; Löw et al. have :math:`s` = 1 sr⁻¹, which ties the fit to the data's
  units: on a dark paint such as Cayman the log is then linear nearly everywhere);
- ``"cube_root"`` (default) — Forés, Ferwerda & Gu (2012):
  :math:`r = (\hat f c_i)^{1/3} - (f c_i)^{1/3}`, which tames the highlight more strongly still;
  in their psychophysical study it gave the fits closest to the measurement by eye.

**Loss.** The residuals count through scipy's robust ``loss`` [7], by default ``"soft_l1"``,
:math:`\rho(r) = 2s^2(\sqrt{1 + (r/s)^2} - 1)`: quadratic below the scale :math:`s`, linear
beyond it. A few samples that the model cannot follow then do not decide the fit. Cayman, a
metallic paint, has a sharp clear-coat peak (6 of its 1439 samples, about a hundred times the
brightest body value) over a broad coloured lobe that covers most of the sphere. Under plain
least squares (``loss="linear"``), Lambertian + one lobe spends the lobe on those 6 samples
and loses the body. The scale is relative: :math:`s` is ``loss_scale`` (½) times the median,
over the measurements, of their mean channel on the objective's scale. Scaling the data by
:math:`k` therefore scales the cube-root residuals and :math:`s` alike (both by
:math:`k^{1/3}`), and the fit is the same. Where the model can fit every sample (a table
written from that model) the residuals go to 0 and the loss changes nothing. A peak strong
enough still wins: the loss tips the balance, it does not remove the peak.

**Free parameters** are the numeric parameters of each lobe that the spec string does not give
explicitly (``"lambertian + ggx(alpha=0.1)"`` fixes α) and that are not listed in ``fixed``;
parameters that do not change the lobe's values (Cook–Torrance's ``f0`` under its default
dielectric Fresnel term, tested on fixed direction pairs) are left alone, and so is a lobe's own
diffuse term (``kd``, ``diffuse``), held at 0 when the model has a Lambertian lobe, which would
make it redundant. A lobe with no colour parameter of its own that acts, free or written (GGX
with F = 1 has none; Cook–Torrance's ``f0`` is inert under its dielectric Fresnel term), gets a
free per-channel factor, fitted as ``[k_r, k_g, k_b] * ggx(...)`` — for Cook–Torrance the
paper's specular weight s; a written factor (``0.5 * ggx``) stays fixed. The **bounds** are the
models' own: each model validates its parameters with :func:`~brdfkit._array.check_param`,
and the allowed interval is read from the message it raises for ±10³⁰ (open ends are moved
inwards by 10⁻⁶). Models with an ``allow_unphysical`` switch are fitted with it on (a joint
limit such as kd + ks ≤ 1 is not a box); the fitted model keeps it on only if its values need
it.

**Channels**: ``mode="shared"`` fits one lobe shape for all channels with per-channel colour
parameters (those named in :data:`COLOUR_PARAMETERS`); ``mode="per_channel"`` fits every channel
independently (every parameter becomes per channel).

**Which objective and loss.** Fitted to the four Cornell paints with five models, the spheres
look most like the measured ones (CIEDE2000 between rendered spheres, :mod:`brdfkit.fit.appearance`;
``benchmarks/bench_cornell_fits.py`` compares them) with a compressing objective, ``cube_root``
or ``log``, under ``soft_l1``; ``cosine`` is far behind. The cosine-weighted error is ruled by
a few grazing or near-mirror samples hundreds of times larger than the rest and trades the body
colour for them. Forés et al. found with observers that the cube root fits closest by eye; it
is the default.

**Starts and samples**: the first start is the model's own parameter values; the others sweep the
lobes' roughness (``alpha``, ``m``, exponents ``n``) log-uniformly over :data:`ROUGHNESS_SWEEP`
with the other parameters at the model's values — a highlight much sharper than the start is
otherwise never found — or, for models without roughness, are drawn at random inside the bounds
(log-uniformly on positive ranges spanning more than a factor 50). Each start first fits its
colours alone (the :data:`COLOUR_PARAMETERS` and the lobes' factors), its shape held, and only then
everything. A start far too bright otherwise escapes through its shape: Cook–Torrance started at
m = 0.4 shrank m to 0.02 and tuned η to dim itself. Every start is optimised on a seeded random
subset of ``coarse_samples`` measurements; the best is refined on ``max_samples`` of them, and the
errors are reported on all.

**Jacobian.** The model is a sum of lobes and a parameter changes one lobe only, so each column
of the forward-difference Jacobian re-evaluates that lobe alone beside the others' cached values,
and a lobe factor's column needs no evaluation at all (scipy's own ``"2-point"`` differences take
P + 1 evaluations of the whole model; ``benchmarks/bench_fit.py`` compares the two). The least
squares runs its SVDs of the tall, narrow Jacobian on one BLAS thread (``_BLAS_THREADS``).
Torch autograd would not make it cheaper: a forward and backward pass costs about one
evaluation and gives a gradient, whereas the trust-region least squares needs the whole
Jacobian (one backward pass per residual, or one forward-mode pass per parameter).

**Memory and repeated work.** A pass over all of a MERL table's 1.11 M measured nodes is bound
by memory traffic (each direction array is 27 MB, each step of a model's evaluation reads and
writes such arrays). So those passes run on cache-sized pieces: the nodes' directions one θh
row at a time from the grid's axes (:meth:`TabulatedBRDF.node_axes`, their sines and cosines
once per axis value), the errors (:func:`fit_errors`) on blocks of 8192 samples. Inside a
least-squares run nothing is computed twice: the measurements' side of the residuals once, a
Jacobian column's residuals only in the channels its step moves, and a lobe whose own
parameters did not change keeps its values. The results are those of the plain computation
(``tests/fit/test_fit_blocks.py``).

References
----------
.. [1] A. Ngan, F. Durand, W. Matusik, "Experimental analysis of BRDF models", EGSR 2005.
.. [2] J. Löw, J. Kronander, A. Ynnerman, J. Unger, "BRDF models for accurate and efficient
       rendering of glossy surfaces", ACM TOG 31(1), 2012.
.. [3] M. A. Branch, T. F. Coleman, Y. Li, "A subspace, interior, and conjugate gradient method
       for large-scale bound-constrained minimization problems", SIAM J. Sci. Comput. 21(1),
       1999 (scipy's ``trf``).
.. [4] W. Matusik, H. Pfister, M. Brand, L. McMillan, "A data-driven reflectance model",
       SIGGRAPH 2003.
.. [5] B. Walter, S. R. Marschner, H. Li, K. E. Torrance, "Microfacet models for refraction
       through rough surfaces", EGSR 2007 (α ↔ Phong exponent, n = 2/α² − 2).
.. [6] A. Forés, J. A. Ferwerda, J. Gu, "Toward a perceptually based metric for BRDF
       modeling", Proc. IS&T Color and Imaging Conference 20, 142–148, 2012.
.. [7] B. Triggs, P. F. McLauchlan, R. I. Hartley, A. W. Fitzgibbon, "Bundle adjustment — a
       modern synthesis", Vision Algorithms: Theory and Practice, LNCS 1883, 2000 (robust
       losses in least squares).
"""

from __future__ import annotations

import ast
import dataclasses
import functools
import math
import re
import time
import weakref
from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any

import numpy as np

from brdfkit._array import to_numpy
from brdfkit.brdf.base import BRDF, SCALE, Scaled, Sum
from brdfkit.errors import ParameterError, SpecError
from brdfkit.fit.coordinates import constrained, coordinate_bounds, unconstrained
from brdfkit.geometry import from_half_diff
from brdfkit.measured.tabulated import MeasuredSamples, TabulatedBRDF
from brdfkit.params import check_choice, parameter_domains

OBJECTIVES = ("cosine", "log", "cube_root")
"""The fitting objectives (see the module docstring)."""

LOSSES = ("soft_l1", "linear", "huber", "cauchy", "arctan")
"""How residuals count (:func:`scipy.optimize.least_squares`'s ``loss``; see the module
docstring)."""

MODES = ("shared", "per_channel")
"""How channels are fitted: one lobe shape with per-channel colours, or each channel alone."""

COLOUR_PARAMETERS = frozenset(
    {
        "albedo",
        "base_color",
        "kd",
        "ks",
        "rho",
        "rho_d",
        "rho_s",
        "specular",
        "diffuse",
        "reflectance",
        "f0",
    }
)
"""Parameter names that hold a colour (one value per channel in ``mode="shared"``)."""

DIFFUSE_PARAMETERS = frozenset({"kd", "diffuse"})
"""A lobe's own diffuse term: held at 0 when the model has a Lambertian lobe, which would make
it redundant."""

LOBE_COLOURS = COLOUR_PARAMETERS - DIFFUSE_PARAMETERS
"""Colour parameters of a lobe itself (not of a diffuse term added to it): a lobe without one
that acts gets a free per-channel factor."""

ROUGHNESS_PARAMETERS = frozenset({"alpha", "alpha_u", "alpha_v", "alpha_x", "alpha_y", "m"})
"""Parameter names that hold a microfacet roughness (swept by the starts of :func:`fit`)."""

EXPONENT_PARAMETERS = frozenset({"n"})
"""Parameter names that hold a Phong-like exponent (swept as ``2/alpha**2 - 2``)."""

ROUGHNESS_SWEEP = (0.002, 0.6)
"""The roughness range that the starts after the first sweep, log-uniformly."""

STARTS = (1, 1000)
"""The allowed range of :func:`fit`'s ``starts``."""

SAMPLES = (10, 100_000_000)
"""The allowed range of :func:`fit`'s ``coarse_samples`` and ``max_samples``."""

EVALUATIONS = (1, 1_000_000)
"""The allowed range of :func:`fit`'s ``max_nfev``."""

_BLAS_THREADS: int | None = 1
"""BLAS threads inside a least-squares run (``None``: the process's own). Its SVDs and products
are of tall, narrow Jacobians (≤ 10⁵ × a dozen), which threads do not speed up; on a busy machine
a threaded OpenBLAS spins and makes them many times slower."""

_JACOBIAN = "lobes"
"""How a least-squares run differentiates: ``"lobes"`` (:class:`_LobeValues`: one lobe
re-evaluated per column, factors free) or ``"2-point"`` (scipy's own differences, P + 1 full
evaluations; the peer in ``benchmarks/bench_fit.py``)."""

_BLOCK = 8192
"""Measurements per block in :func:`fit_errors`, which passes over all of them. A MERL table
has 1.11 M measured nodes: each of their direction arrays is 27 MB, and every step of a
model's evaluation on them reads and writes memory; on blocks of 8192 (196 KB per direction
array) the temporaries stay in the cores' caches."""

_OPEN_MARGIN = 1e-6
_BIG = 1e30
_INTERVAL = re.compile(r"must be in ([\[(])(\S+), (\S+?)([\])])")

Progress = Callable[[float, int, str], None]
"""``progress(completed, total, description)``: completed stages (fractional) out of total."""


# --------------------------------------------------------------------------- data
def fit_data(
    measured: BRDF | MeasuredSamples, samples: int = 200_000, seed: int = 0
) -> MeasuredSamples:
    """The measurements a fit uses, as :class:`MeasuredSamples` (only valid ones).

    - :class:`MeasuredSamples`: themselves;
    - a :class:`TabulatedBRDF` built from scattered samples (Cornell): those raw samples;
    - any other :class:`TabulatedBRDF` (MERL): its grid nodes;
    - any other BRDF (RGL, an analytic model): ``samples`` random pairs (wi, wo), both uniform
      on the hemisphere (seeded), evaluated.

    Examples
    --------
    >>> from brdfkit.brdf import Lambertian
    >>> data = fit_data(Lambertian(rho=[0.5, 0.4, 0.3]), samples=1000)
    >>> data.wi.shape, data.values.shape, bool(data.valid.all())
    ((1000, 3), (1000, 3), True)
    """
    if isinstance(measured, TabulatedBRDF) and measured.samples is not None:
        measured = measured.samples
    if isinstance(measured, MeasuredSamples):
        data = measured
    elif isinstance(measured, TabulatedBRDF):
        return _node_samples(measured)
    elif isinstance(measured, BRDF):
        from brdfkit.sampling import hemisphere_pairs

        wi, wo = hemisphere_pairs(samples, seed)
        values = to_numpy(measured.eval(wi, wo))
        data = MeasuredSamples(wi, wo, values, name=getattr(measured, "name", repr(measured)))
    else:
        raise ParameterError(
            f"measured must be a BRDF or MeasuredSamples; got {type(measured).__name__}"
        )
    valid = data.valid
    if valid.all():  # as fit_data returns them (a batch reuses them): no copies
        return data
    return dataclasses.replace(
        data,
        wi=data.wi[valid],
        wo=data.wo[valid],
        values=data.values[valid],
        spectral=None if data.spectral is None else data.spectral[valid],
    )


def _node_samples(table: TabulatedBRDF) -> MeasuredSamples:
    """The measured (valid) grid nodes of ``table``, their directions computed one row of θh
    at a time (:meth:`TabulatedBRDF.node_directions` on all at once writes 35 MB arrays for a
    MERL table); for an isotropic table from the grid's axes
    (:meth:`TabulatedBRDF.node_axes`), whose sines and cosines are then taken once per axis
    value, not per node."""
    axes = table.node_axes()
    if not table.isotropic:  # the rotations by φh would not broadcast the other angles
        axes = np.broadcast_arrays(*axes)
    values = table.scaled_values()
    nodes = math.prod(table.shape)
    out = (np.empty((nodes, 3)), np.empty((nodes, 3)), np.empty((nodes, table.channels)))
    count = 0  # the measured nodes written so far, row after row
    for row in range(table.shape[0]):
        block = slice(row, row + 1)
        wi, wo = from_half_diff(*(a if a.shape[0] == 1 else a[block] for a in axes))
        found = MeasuredSamples(
            wi.reshape(-1, 3), wo.reshape(-1, 3), values[block].reshape(-1, table.channels)
        )
        valid = found.valid
        stop = count + int(np.count_nonzero(valid))
        for whole, part in zip(out, (found.wi, found.wo, found.values), strict=True):
            np.compress(valid, part, axis=0, out=whole[count:stop])
        count = stop
    return MeasuredSamples(*(whole[:count] for whole in out), name=table.name)


def _rows(data: MeasuredSamples, rows: slice | np.ndarray) -> MeasuredSamples:
    """The measurements ``rows`` of ``data`` (directions and values)."""
    return MeasuredSamples(data.wi[rows], data.wo[rows], data.values[rows], name=data.name)


def residuals(model: BRDF, data: MeasuredSamples, objective: str = "cosine") -> np.ndarray:
    r"""The residuals ``(N, C)`` of ``model`` on ``data`` under ``objective``.

    ``"cosine"``: :math:`(\hat f - f)\cos\theta_i`; ``"log"``:
    :math:`\ln(1+\hat f\cos\theta_i/s) - \ln(1+f\cos\theta_i/s)` with :math:`s` the data's
    own level (:func:`log_scale`); ``"cube_root"``:
    :math:`(\hat f\cos\theta_i)^{1/3} - (f\cos\theta_i)^{1/3}`.

    References
    ----------
    .. [1] A. Ngan, F. Durand, W. Matusik, EGSR 2005. .. [2] J. Löw et al., ACM TOG 2012.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit.brdf import Lambertian
    >>> data = fit_data(Lambertian(rho=0.5), samples=100)
    >>> r = residuals(Lambertian(rho=0.5), data, "cube_root")
    >>> r.shape, float(np.abs(r).max())
    ((100, 1), 0.0)
    """
    check_choice("objective", objective, OBJECTIVES)
    return _residuals(_predicted(model, data), data, objective, log_scale(data))


def log_scale(data: MeasuredSamples) -> float:
    r"""The level :math:`s` of the ``"log"`` objective :math:`\ln(1 + f\cos\theta_i / s)`: the
    median over the measurements of their mean channel :math:`f\cos\theta_i` (1 if that is 0).

    Löw et al.'s form has :math:`s = 1` sr⁻¹, which makes the fit depend on the data's units and
    exposure: for a dark material (:math:`f\cos\theta_i \ll 1` but at its highlight) the
    logarithm is then linear almost everywhere and the highlight's few bright samples dominate
    the fit, while a bright one is compressed everywhere. With the data's own level the log is
    linear below the material's typical value and logarithmic above it whatever its albedo:
    scaling all measurements by :math:`k` scales the fitted colours by :math:`k` and leaves the
    shape parameters unchanged, as under ``"cube_root"``.

    References
    ----------
    .. [1] J. Löw, J. Kronander, A. Ynnerman, J. Unger, "BRDF models for accurate and efficient
           rendering of glossy surfaces", ACM TOG 31(1), 2012 (the log objective, :math:`s=1`).

    Examples
    --------
    The level follows the data: twice as bright, twice the level.

    >>> from brdfkit.brdf import Lambertian
    >>> dim = log_scale(fit_data(Lambertian(rho=0.25), samples=1000))
    >>> bright = log_scale(fit_data(Lambertian(rho=0.5), samples=1000))
    >>> round(bright / dim, 12)
    2.0
    """
    return _measured_side(data).level


@dataclass(frozen=True, eq=False)
class _MeasuredSide:
    """The measurements' side of every objective's residuals: ``compressed[objective]``
    (:func:`_compressed` of all the values, ``(N, C)``, the log objective's at ``level``,
    :func:`log_scale`)."""

    level: float
    compressed: dict[str, np.ndarray]


def _measured_side(data: MeasuredSamples) -> _MeasuredSide:
    """The :class:`_MeasuredSide` of ``data``, computed once per ``data`` object and kept while
    it lives (:data:`_MEASURED_SIDES`).

    A batch fits each file with several models (:mod:`brdfkit.distributed.batch`), and every fit
    needs the log level, its objective's typical size and, for its errors, all three
    objectives' measured sides: for a MERL table that is 1.11 M × 3 cube roots and
    logarithms each, per fit, as costly as a fit's least squares. Kept, they cost 3 arrays of
    the values' size (27 MB each for MERL) while ``data`` lives. Computed on cache-sized
    blocks (:data:`_BLOCK`), element by element, so the results equal the whole-array ones.
    """
    key = id(data)
    if key in _MEASURED_SIDES and _MEASURED_SIDES[key][0]() is data:
        return _MEASURED_SIDES[key][1]
    compressed = {objective: np.empty(data.values.shape) for objective in OBJECTIVES}
    level = 1.0
    for objective in OBJECTIVES:  # "cosine" first: its typical size is the log level
        for start in range(0, data.wi.shape[0], _BLOCK):
            rows = slice(start, start + _BLOCK)
            compressed[objective][rows] = _compressed(
                data.values[rows], data.wi[rows, 2:3], objective, level
            )
        if objective == "cosine":
            level = _median_size(compressed[objective])
    side = _MeasuredSide(level, compressed)
    _MEASURED_SIDES[key] = (weakref.ref(data, lambda _: _MEASURED_SIDES.pop(key, None)), side)
    return side


_MEASURED_SIDES: dict[int, tuple[weakref.ref, _MeasuredSide]] = {}
""":func:`_measured_side` by ``id`` of the measurements (with a weak reference to them, which
removes the entry when they go)."""


def _predicted(model: BRDF, data: MeasuredSamples) -> np.ndarray:
    """``model``'s values at the measurements' direction pairs, shaped like ``data.values``
    (:func:`_evaluated`)."""
    return np.broadcast_to(_evaluated(model, data.wi, data.wo), data.values.shape)


def _evaluated(model: BRDF, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """``model.eval(wi, wo)`` in float64 by its compiled kernel where that kernel is already
    built in this process or held by the disk cache (:func:`build_kernels`,
    :meth:`~brdfkit.compiled.CompiledBRDF.cached`) and serves every parameter value
    (:meth:`~brdfkit.compiled.CompiledBRDF.shares`); by NumPy otherwise. Nothing is built here:
    building a model's kernels takes seconds, more than a small fit.

    A fit evaluates its model hundreds of times, and its errors on all the measurements: NumPy
    runs a model one operation at a time, each writing a full-size temporary array, where the
    kernel makes one pass. The values differ by 10⁻¹⁵–10⁻¹³ relative (the kernels' fast-math
    contractions and reassociation, :data:`brdfkit.compiled.jit.FASTMATH`).
    """
    from brdfkit.compiled import compile

    compiled = compile(model, np.float64)
    try:
        if compiled.cached("eval") and compiled.shares("eval"):
            return compiled.eval(wi, wo)
    except ValueError:  # a primitive the kernels do not take (not tried again: shares)
        pass
    return to_numpy(model.eval(wi, wo))


def build_kernels(model: BRDF | str) -> None:
    """Build (or load from the disk cache, :mod:`brdfkit.compiled.cache`) the float64 eval
    kernels that fits of ``model`` use: the model's and each of its lobes'
    (:func:`_evaluated`). Batches call it before their fits (:mod:`brdfkit.distributed.batch`):
    a few seconds once per machine and structure, then every fit of that structure runs
    compiled. A structure whose kernel would bake its parameter values in, or that the
    kernels cannot compile, is recorded as such and stays on NumPy.
    """
    from brdfkit.brdf import parse
    from brdfkit.compiled import compile

    model = parse(model) if isinstance(model, str) else model
    for candidate in (model, *(lobe.inner for lobe in _lobes(model))):
        try:
            compile(candidate, np.float64).shares("eval")
        except ValueError:  # a primitive the kernels do not take: NumPy
            pass


def _residuals(
    predicted: np.ndarray, data: MeasuredSamples, objective: str, scale: float
) -> np.ndarray:
    """The residuals of :func:`residuals`, from the model's values (``scale``: the log
    objective's level, :func:`log_scale`)."""
    cos_theta_i = data.wi[:, 2:3]
    return _compressed_model(predicted, cos_theta_i, objective, scale) - _compressed(
        data.values, cos_theta_i, objective, scale
    )


def _compressed_model(
    predicted: np.ndarray, cos_theta_i: np.ndarray, objective: str, scale: float
) -> np.ndarray:
    """A model's values on the scale of ``objective``'s residuals (:func:`_compressed`)."""
    if objective == "log":  # the model may undershoot to negative values; its log must exist
        predicted = np.maximum(predicted, 0)
    return _compressed(predicted, cos_theta_i, objective, scale)


def _compressed(f: np.ndarray, cos_theta_i: np.ndarray, objective: str, scale: float) -> np.ndarray:
    r"""BRDF values ``f`` on the scale of ``objective``'s residuals: :math:`f\cos\theta_i`,
    :math:`\ln(1 + f\cos\theta_i / s)` (``scale`` :math:`s`, :func:`log_scale`) or
    :math:`(f\cos\theta_i)^{1/3}`."""
    if objective == "cosine":
        return f * cos_theta_i
    if objective == "log":
        return np.log1p(f * cos_theta_i / scale)
    return np.cbrt(f * cos_theta_i)


def fit_errors(model: BRDF, data: MeasuredSamples) -> dict[str, float]:
    r"""Errors of ``model`` against ``data`` by several metrics (all channels pooled).

    ``rmse`` :math:`\sqrt{\overline{(\hat f - f)^2}}` (sr⁻¹); ``cosine_rmse`` Ngan et al.'s
    :math:`\sqrt{\overline{((\hat f - f)\cos\theta_i)^2}}`; ``relative_l2``
    :math:`\lVert\hat f - f\rVert_2 / \lVert f\rVert_2`; ``log_rmse`` the RMS of the ``"log"``
    residuals; ``cube_root_rmse`` the RMS of the ``"cube_root"`` residuals.

    References
    ----------
    .. [1] A. Ngan, F. Durand, W. Matusik, EGSR 2005.

    Examples
    --------
    A Lambertian of albedo 0.5 against data of albedo 0.4: f differs by 0.1/π everywhere,
    a quarter of the data's values:

    >>> import math
    >>> from brdfkit.brdf import Lambertian
    >>> errors = fit_errors(Lambertian(rho=0.5), fit_data(Lambertian(rho=0.4), samples=1000))
    >>> round(errors["rmse"] * math.pi, 12), round(errors["relative_l2"], 12)
    (0.1, 0.25)
    """
    return _errors(model, data)


def _errors(model: BRDF, data: MeasuredSamples) -> dict[str, float]:
    """:func:`fit_errors`, the measurements' side from :func:`_measured_side`."""
    side = _measured_side(data)
    squares = dict.fromkeys(("rmse", "cosine_rmse", "log_rmse", "cube_root_rmse", "data"), 0.0)
    for start in range(0, data.wi.shape[0], _BLOCK):  # cache-sized blocks (see _BLOCK)
        rows = slice(start, start + _BLOCK)
        wi, values = data.wi[rows], data.values[rows]
        predicted = np.broadcast_to(_evaluated(model, wi, data.wo[rows]), values.shape)
        diff = predicted - values
        squares["rmse"] += float(np.sum(diff * diff))
        squares["data"] += float(np.sum(values * values))
        cos_theta_i = wi[:, 2:3]
        for objective in OBJECTIVES:
            model_side = _compressed_model(predicted, cos_theta_i, objective, side.level)
            r = model_side - side.compressed[objective][rows]
            squares[f"{objective}_rmse"] += float(np.sum(r * r))
    count = data.values.size
    return {
        "rmse": math.sqrt(squares["rmse"] / count),
        "cosine_rmse": math.sqrt(squares["cosine_rmse"] / count),
        "relative_l2": math.sqrt(squares["rmse"]) / max(math.sqrt(squares["data"]), 1e-300),
        "log_rmse": math.sqrt(squares["log_rmse"] / count),
        "cube_root_rmse": math.sqrt(squares["cube_root_rmse"] / count),
    }


# --------------------------------------------------------------------------- parameters
@dataclass(frozen=True)
class _Free:
    """One free parameter of one lobe: ``size`` values in ``[lower, upper]``."""

    lobe: int
    name: str
    size: int
    lower: float
    upper: float
    initial: np.ndarray
    sequence: bool


def _bounds(lobe: BRDF, name: str) -> tuple[float, float]:
    """The interval ``lobe``'s model allows for parameter ``name`` given its other settings
    (``allow_unphysical`` on), read from its validation."""
    cls = type(lobe)
    extra = {"allow_unphysical": True} if "allow_unphysical" in _field_names(cls) else {}
    ends = []
    for probe in (-_BIG, _BIG):
        try:
            dataclasses.replace(lobe, **extra, **{name: probe})
        except (ValueError, TypeError) as error:
            match = _INTERVAL.search(str(error))
            if not match or not str(error).startswith(name):
                raise ValueError(
                    f"cannot read the range of parameter {name!r} of model {cls.spec_name!r} "
                    f"from its validation ({error}); fix it with fixed=({name!r},)"
                ) from None
            left, lo, hi, right = match.groups()
            lo_v, hi_v = float(lo), float(hi)
            if left == "(":
                lo_v += _OPEN_MARGIN * max(1.0, abs(lo_v))
            if right == ")":
                hi_v -= _OPEN_MARGIN * max(1.0, abs(hi_v))
            ends.append(lo_v if probe < 0 else hi_v)
        else:
            ends.append(-math.inf if probe < 0 else math.inf)
    domain = parameter_domains(cls).get(name)
    if domain is not None:  # a wide declared end that the probes at ±10³⁰ do not reach
        hi = domain.unphysical_hi if extra and domain.unphysical_hi is not None else domain.hi
        ends = [max(ends[0], domain.lo), min(ends[1], hi)]
    return ends[0], ends[1]


@functools.cache
def _field_names(cls: type[BRDF]) -> tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(cls) if f.init)  # type: ignore[arg-type]


@dataclass(frozen=True, eq=False)
class _Lobe:
    """One term ``scale * inner`` of the model (``scale`` None: no factor)."""

    inner: BRDF
    scale: Any = None


def _lobes(model: BRDF) -> list[_Lobe]:
    lobes = []
    for term in model.lobes if isinstance(model, Sum) else (model,):
        lobe = _Lobe(term.inner, term.k) if isinstance(term, Scaled) else _Lobe(term)
        if not lobe.inner.spec_name or type(lobe.inner) is not _registered(lobe.inner):
            raise ParameterError(
                "model must be a sum of registered models, each optionally scaled (k * model); "
                f"got {term!r} ({type(term).__name__})"
            )
        lobes.append(lobe)
    return lobes


def _registered(lobe: BRDF) -> type | None:
    from brdfkit.brdf import MODELS

    return MODELS.get(lobe.spec_name)


def _explicit_keywords(spec: str) -> list[set[str]]:
    """The parameter names written in each lobe of ``spec`` (``"scale"`` for a written
    factor), lobes in order."""
    out: list[set[str]] = []
    stack = [(ast.parse(spec.strip(), mode="eval").body, frozenset())]
    while stack:  # depth first, left to right, without recursion (a sum may be long)
        node, written = stack.pop()
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add) and not written:
            stack += [(node.right, written), (node.left, written)]
        elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
            model_side = node.right if isinstance(node.right, ast.Call | ast.Name) else node.left
            stack.append((model_side, written | {"scale"}))
        elif isinstance(node, ast.Call):
            out.append(set(written) | {k.arg for k in node.keywords if k.arg})
        elif isinstance(node, ast.Name):
            out.append(set(written))
        else:
            raise SpecError(
                f"spec {spec!r:.80}: fitting supports a sum of (optionally scaled) models; "
                f"got {ast.get_source_segment(spec.strip(), node)!r:.80}"
            )
    return out


def _check_fixed(fixed: Collection[str], lobes: list[_Lobe]) -> None:
    """Raise :class:`~brdfkit.errors.ParameterError` unless every entry of ``fixed`` names a
    numeric parameter (or ``"scale"``) of some lobe, or ``"<k>.<name>"`` of lobe k."""
    if isinstance(fixed, str) or not isinstance(fixed, Collection):
        raise ParameterError(f"fixed must be a collection of parameter names; got {fixed!r:.60}")
    names = [
        {"scale"}
        | {n for n in _field_names(type(lobe.inner)) if _is_numeric(getattr(lobe.inner, n))}
        for lobe in lobes
    ]
    known = [f"{k}.{n}" for k, lobe_names in enumerate(names) for n in sorted(lobe_names)]
    for entry in fixed:
        lobe, _, name = entry.rpartition(".") if isinstance(entry, str) else ("", "", None)
        valid = (
            name in set().union(*names)
            if not lobe
            else lobe.isdigit() and int(lobe) < len(names) and name in names[int(lobe)]
        )
        if not valid:
            raise ParameterError(
                f"fixed names {entry!r:.60}, which is no parameter of the model; its "
                f"parameters are {', '.join(known)} (a name alone holds it in every lobe)"
            )


def _is_integer(value: Any) -> bool:
    return isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float | np.floating | np.integer) and not isinstance(value, bool)


def _is_numeric(value: Any) -> bool:
    if isinstance(value, list | tuple | np.ndarray):
        return np.size(value) > 0 and all(_is_number(v) for v in np.ravel(value))
    return _is_number(value)


def _probe_directions() -> tuple[np.ndarray, np.ndarray]:
    """Fixed direction pairs on which a parameter's effect is tested."""
    from brdfkit.sampling import square_to_cosine_hemisphere

    rng = np.random.default_rng(12345)
    return square_to_cosine_hemisphere(rng.random((256, 2))), square_to_cosine_hemisphere(
        rng.random((256, 2))
    )


def _inert(lobe: BRDF, name: str, value: np.ndarray, lower: float, upper: float) -> bool:
    """Whether changing parameter ``name`` leaves ``lobe``'s values unchanged (e.g. Schlick's
    f0 under a dielectric Fresnel term): such parameters are not fitted."""
    wi, wo = _probe_directions()
    reference = to_numpy(lobe.eval(wi, wo))
    for moved in (value * 1.25 + 0.05, value * 0.8 - 0.05):
        moved = np.clip(moved, lower, upper)
        if np.array_equal(moved, value):
            continue
        change = (
            float(moved[0])
            if moved.size == 1 and np.ndim(getattr(lobe, name)) == 0
            else (moved.tolist())
        )
        try:
            other = dataclasses.replace(lobe, **{name: change})
        except ValueError:
            return False
        return np.array_equal(to_numpy(other.eval(wi, wo)), reference)
    return False


def _free_parameters(
    lobes: list[_Lobe], explicit: list[set[str]], fixed: Collection[str], channels: int
) -> list[_Free]:
    has_lambertian = any(lobe.inner.spec_name == "lambertian" for lobe in lobes)
    free = []
    for k, lobe in enumerate(lobes):
        inner = lobe.inner
        coloured = False  # whether a colour parameter of its own lobe acts (held or free)
        for name in _field_names(type(inner)):
            value = getattr(inner, name)
            held = name in explicit[k] or name in fixed or f"{k}.{name}" in fixed
            redundant = has_lambertian and name in DIFFUSE_PARAMETERS
            if redundant or not _is_numeric(value):
                continue
            if held:
                coloured |= name in LOBE_COLOURS
                continue
            lower, upper = _bounds(inner, name)
            size = (
                channels
                if name in COLOUR_PARAMETERS and _takes_channels(inner, name, channels)
                else int(np.size(value))
            )
            flat = np.ravel(np.asarray(value, dtype=np.float64))
            initial = np.clip(
                flat if flat.size == size else np.full(size, flat.mean()), lower, upper
            )
            if _inert(inner, name, np.ravel(np.asarray(value, dtype=np.float64)), lower, upper):
                continue
            coloured |= name in LOBE_COLOURS and size == channels
            sequence = isinstance(value, list | tuple | np.ndarray)
            free.append(_Free(k, name, size, lower, upper, initial, sequence))
        wants_scale = lobe.scale is not None or not coloured
        held = "scale" in explicit[k] or "scale" in fixed or f"{k}.scale" in fixed
        if wants_scale and not held:
            start = 1.0 if lobe.scale is None else np.ravel(to_numpy(lobe.scale)).astype(float)
            initial = np.broadcast_to(start, (channels,)).copy()
            free.append(_Free(k, "scale", channels, SCALE.lo, SCALE.hi, initial, True))
    if not free:
        raise ParameterError(
            "the model has no free parameter to fit (all are fixed or non-numeric)"
        )
    return free


def _takes_channels(lobe: BRDF, name: str, channels: int) -> bool:
    """Whether ``lobe``'s model takes one value of ``name`` per channel (an albedo does; a
    principled weight, one per point, does not)."""
    extra = {"allow_unphysical": True} if "allow_unphysical" in _field_names(type(lobe)) else {}
    value = float(np.mean(np.asarray(getattr(lobe, name), dtype=np.float64)))
    try:
        dataclasses.replace(lobe, **extra, **{name: [value] * channels})
    except ParameterError:
        return False
    return True


def _without_redundant_diffuse(lobes: list[_Lobe], explicit: list[set[str]]) -> list[_Lobe]:
    """Beside a Lambertian lobe, other lobes' own diffuse terms are set to 0 (unless written)."""
    if not any(lobe.inner.spec_name == "lambertian" for lobe in lobes):
        return lobes
    out = []
    for lobe, written in zip(lobes, explicit, strict=True):
        names = set(_field_names(type(lobe.inner))) & DIFFUSE_PARAMETERS
        zeros = {name: 0.0 for name in names - written if _is_numeric(getattr(lobe.inner, name))}
        out.append(dataclasses.replace(lobe, inner=dataclasses.replace(lobe.inner, **zeros)))
    return out


def _assemble(lobes: list[_Lobe], free: list[_Free], x: np.ndarray, relax: bool) -> BRDF:
    """The model with the free parameters set from the vector ``x``."""
    built = [
        inner if scale is None else Scaled(scale, inner)
        for inner, scale in _terms(lobes, free, x, relax)
    ]
    return built[0] if len(built) == 1 else Sum(tuple(built))


def _terms(
    lobes: list[_Lobe], free: list[_Free], x: np.ndarray, relax: bool, only: int | None = None
) -> list[tuple[BRDF, Any]]:
    """Each lobe as ``(inner model, factor or None)`` with the free parameters set from ``x``
    (only lobe ``only`` if given: a one-element list)."""
    changes, scales = _settings(lobes, free, x)
    terms = []
    for k, (lobe, change, scale) in enumerate(zip(lobes, changes, scales, strict=True)):
        if only is not None and k != only:
            continue
        if relax and "allow_unphysical" in _field_names(type(lobe.inner)):
            change["allow_unphysical"] = True
        terms.append((dataclasses.replace(lobe.inner, **change) if change else lobe.inner, scale))
    return terms


def _settings(
    lobes: list[_Lobe], free: list[_Free], x: np.ndarray
) -> tuple[list[dict[str, Any]], list[Any]]:
    """Each lobe's parameters set from ``x`` (by name) and its factor (``None``: none)."""
    changes: list[dict[str, Any]] = [{} for _ in lobes]
    scales = [lobe.scale for lobe in lobes]
    i = 0
    for p in free:
        values = x[i : i + p.size]
        i += p.size
        value = float(values[0]) if p.size == 1 and not p.sequence else [float(v) for v in values]
        if p.name == "scale":
            scales[p.lobe] = value
        else:
            changes[p.lobe][p.name] = value
    return changes, scales


def _physical(model: BRDF) -> BRDF:
    """``model`` with ``allow_unphysical`` switched back off in every lobe that allows it."""
    terms = []
    for lobe in _lobes(model):
        inner = lobe.inner
        if "allow_unphysical" in _field_names(type(inner)):
            try:
                inner = dataclasses.replace(inner, allow_unphysical=False)
            except ValueError:
                pass
        terms.append(inner if lobe.scale is None else Scaled(lobe.scale, inner))
    return terms[0] if len(terms) == 1 else Sum(tuple(terms))


def _random_start(free: list[_Free], rng: np.random.Generator) -> np.ndarray:
    """A random starting point inside the bounds."""
    parts = []
    for p in free:
        lo, hi = p.lower, p.upper
        if math.isfinite(lo) and math.isfinite(hi):
            if lo >= 0 and hi / max(lo, 1e-3) > 50:
                lo_l, hi_l = math.log(max(lo, 1e-3)), math.log(hi)
                parts.append(np.exp(rng.uniform(lo_l, hi_l, p.size)))
            else:
                parts.append(rng.uniform(lo, hi, p.size))
        else:
            centre = np.maximum(np.abs(p.initial), 1e-3)
            sample = centre * np.exp(rng.uniform(-math.log(10), math.log(10), p.size))
            parts.append(np.clip(np.where(p.initial < 0, -sample, sample), lo, hi))
    return np.concatenate(parts)


def _starts(free: list[_Free], count: int, rng: np.random.Generator) -> list[np.ndarray]:
    """``count`` starting points: the model's own values, then a sweep of its roughness.

    The roughness of a lobe decides which local minimum a fit falls into (a highlight far
    sharper than the start is never found), so the later starts sweep every roughness
    parameter log-uniformly over :data:`ROUGHNESS_SWEEP` — exponents as
    :math:`n = 2/\\alpha^2 - 2` (Walter et al. 2007) — with the other parameters at the model's
    values. A model without roughness gets random starts inside the bounds."""
    initial = np.concatenate([p.initial for p in free])
    if not any(p.name in ROUGHNESS_PARAMETERS | EXPONENT_PARAMETERS for p in free):
        return [initial] + [_random_start(free, rng) for _ in range(count - 1)]
    sweep = np.geomspace(*ROUGHNESS_SWEEP, count - 1) if count > 1 else []
    return [initial] + [np.concatenate([_swept(p, alpha) for p in free]) for alpha in sweep]


def _swept(p: _Free, alpha: float) -> np.ndarray:
    """Parameter ``p`` at roughness ``alpha`` (its own values if it is no roughness)."""
    if p.name in ROUGHNESS_PARAMETERS:
        value = alpha
    elif p.name in EXPONENT_PARAMETERS:
        value = 2 / alpha**2 - 2
    else:
        return p.initial
    return np.clip(np.full(p.size, value), p.lower, p.upper)


def _is_colour(p: _Free) -> bool:
    """Whether ``p`` sets a lobe's colour or strength (levelled first from every start)."""
    return p.name in COLOUR_PARAMETERS or p.name == "scale"


def _median_size(compressed: np.ndarray) -> float:
    """The median over the measurements of their mean channel of ``compressed`` (measured
    values on an objective's scale, ``(N, C)``; 1 if that is 0: most measurements black)."""
    means = np.empty(compressed.shape[0])
    for start in range(0, means.size, _BLOCK):  # cache-sized blocks (see _BLOCK)
        rows = slice(start, start + _BLOCK)
        np.abs(compressed[rows]).mean(axis=1, out=means[rows])
    size = float(np.median(means, overwrite_input=True))
    return size if size > 0 else 1.0


def _subset(data: MeasuredSamples, count: int, rng: np.random.Generator) -> MeasuredSamples:
    if data.wi.shape[0] <= count:
        return data
    return _rows(data, np.sort(rng.choice(data.wi.shape[0], count, replace=False)))


# --------------------------------------------------------------------------- results
@dataclass(frozen=True, eq=False)
class FitResult:
    """The outcome of :func:`fit`.

    Attributes
    ----------
    model : the fitted BRDF. spec : it as a spec string (:func:`brdfkit.brdf.parse` reads it).
    params : fitted free parameters by ``"<lobe index>.<model>.<name>"``.
    errors : :func:`fit_errors` on all valid measurements.
    objective, loss, mode : as requested. loss_scale : the residual scale the loss used
    (absolute). cost : the final loss on the refinement set (½Σr² for ``"linear"``).
    starts : restarts tried. nfev : residual evaluations and Jacobians in all. samples :
    measurements in the errors. fit_samples : measurements in the refinement. success,
    message : from scipy. seconds : wall time.
    """

    model: BRDF
    spec: str
    params: dict[str, Any]
    errors: dict[str, float]
    objective: str
    loss: str
    loss_scale: float
    mode: str
    cost: float
    starts: int
    nfev: int
    samples: int
    fit_samples: int
    success: bool
    message: str
    seconds: float

    def to_dict(self) -> dict[str, Any]:
        """A JSON-serialisable summary (everything but the model object)."""
        return {
            f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "model"
        }


@dataclass(frozen=True)
class _Robust:
    """What a least-squares run minimises: ``objective``'s residuals (the log objective's at
    level ``log_scale``, :func:`log_scale` of all the measurements) under scipy's ``loss``,
    which counts residuals beyond ``f_scale`` less than quadratically."""

    objective: str
    loss: str
    f_scale: float
    log_scale: float


class _LobeValues:
    r"""The model's values lobe by lobe at the measurements, and its residuals' Jacobian.

    The model is a sum :math:`\hat f = \sum_j k_j g_j(\theta_j)`; a parameter of lobe
    :math:`j` changes that lobe alone, so each column of the forward-difference Jacobian
    re-evaluates one lobe (:math:`g_j` at :math:`\theta_j + h e`) and adds it to the other lobes'
    cached values; a factor's column needs no evaluation (:math:`k_j + h e` times the cached
    :math:`g_j`). The columns are scipy's ``"2-point"`` differences (its step
    :math:`h = \sqrt{\epsilon}\max(1, |x|)`, turned back where it would cross a bound), at a
    fraction of the (P + 1) full evaluations. The measurements' side of the residuals is
    computed once; a column's residuals are recomputed only in the channels whose model values
    the step changed (one, for a colour or a factor; the others' differences are exactly 0);
    a lobe whose own parameters (its factor aside) did not change since its last evaluation
    keeps its values (while only colours are fitted, the lobes without one are evaluated once).
    """

    def __init__(
        self,
        lobes: list[_Lobe],
        free: list[_Free],
        data: MeasuredSamples,
        level: float | None = None,
    ):
        self.lobes, self.free, self.data = lobes, free, data
        self.level = log_scale(data) if level is None else level  # the log objective's s
        self.owner = [(p, j) for p in free for j in range(p.size)]
        self._key: bytes | None = None
        self._values: list[tuple[np.ndarray, np.ndarray]] = []
        self.cos_theta_i = np.ascontiguousarray(data.wi[:, 2:3])
        self._measured: dict[tuple[Any, ...], np.ndarray] = {}
        self.shape_entries = [
            [i for i, (p, _) in enumerate(self.owner) if p.lobe == k and p.name != "scale"]
            for k in range(len(lobes))
        ]
        self._shapes: dict[int, tuple[bytes, np.ndarray]] = {}

    def measured(self, objective: str, channels: slice) -> np.ndarray:
        """The measurements' side of the residuals in ``channels`` (computed once)."""
        key = (objective, channels.start, channels.stop, channels.step)
        if key not in self._measured:
            values = self.data.values[:, channels]
            self._measured[key] = _compressed(values, self.cos_theta_i, objective, self.level)
        return self._measured[key]

    def residuals(self, predicted: np.ndarray, objective: str, channels: slice) -> np.ndarray:
        """The residuals ``(N, C)`` of the model values ``predicted`` in ``channels``
        (:func:`_residuals`)."""
        model = _compressed_model(predicted[:, channels], self.cos_theta_i, objective, self.level)
        return model - self.measured(objective, channels)

    def _term_values(self, inner: BRDF, scale: Any) -> tuple[np.ndarray, np.ndarray]:
        g = np.broadcast_to(_evaluated(inner, self.data.wi, self.data.wo), self.data.values.shape)
        return g, np.asarray(1.0 if scale is None else scale, dtype=np.float64)

    def values(self, x: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """``(g_j, k_j)`` of every lobe at ``x`` (cached for the last ``x``; each ``g_j`` for
        the last values of lobe j's own parameters)."""
        key = x.tobytes()
        if key != self._key:
            _, scales = _settings(self.lobes, self.free, x)
            self._values = []
            for k, scale in enumerate(scales):
                shape = x[self.shape_entries[k]].tobytes()
                if k not in self._shapes or self._shapes[k][0] != shape:
                    ((inner, _),) = _terms(self.lobes, self.free, x, relax=True, only=k)
                    self._shapes[k] = (shape, self._term_values(inner, scale)[0])
                g = self._shapes[k][1]
                self._values.append((g, np.asarray(1.0 if scale is None else scale, dtype=float)))
            self._key = key
        return self._values

    @staticmethod
    def total(values: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
        total = values[0][1] * values[0][0]
        for g, k in values[1:]:
            total = total + k * g
        return total

    def jacobian(
        self,
        x: np.ndarray,
        columns: np.ndarray,
        lower: np.ndarray,
        upper: np.ndarray,
        robust: _Robust,
        channels: slice,
    ) -> np.ndarray:
        """The forward-difference Jacobian of the raveled residuals in ``channels`` over the
        entries ``columns``."""
        objective = robust.objective
        values = self.values(x)
        total = self.total(values)
        r0 = self.residuals(total, objective, channels)
        measured = self.measured(objective, channels)
        jacobian = np.empty((r0.shape[0], r0.shape[1], columns.size))
        for c, i in enumerate(columns):
            p, j = self.owner[i]
            h = math.sqrt(np.finfo(np.float64).eps) * max(1.0, abs(x[i])) * (1 if x[i] >= 0 else -1)
            if not lower[i] <= x[i] + h <= upper[i] and lower[i] <= x[i] - h <= upper[i]:
                h = -h
            h = (x[i] + h) - x[i]
            g, k = values[p.lobe]
            if p.name == "scale":
                step = np.zeros(np.broadcast_shapes(k.shape, (p.size,)))
                step[j] = h
                changed = total + step * g
            else:
                x_step = x.copy()
                x_step[i] += h
                ((inner, scale),) = _terms(self.lobes, self.free, x_step, relax=True, only=p.lobe)
                g_step, k_step = self._term_values(inner, scale)
                changed = total - k * g + k_step * g_step
            moved = np.any(changed[:, channels] != total[:, channels], axis=0)
            if moved.all():
                jacobian[:, :, c] = (self.residuals(changed, objective, channels) - r0) / h
            else:  # (r - r0) / h with r = r0 in the channels not moved
                jacobian[:, :, c] = 0.0 / h
                r = _compressed_model(
                    changed[:, channels][:, moved], self.cos_theta_i, objective, self.level
                )
                jacobian[:, moved, c] = (r - measured[:, moved] - r0[:, moved]) / h
        return jacobian.reshape(-1, columns.size)


class _Coordinates:
    r"""The free parameters ``x`` as a map :math:`x = T(u)` of unconstrained coordinates
    (:mod:`brdfkit.fit.coordinates`): each into its own range, and where a model joins
    parameters by a condition (:data:`JOINT_LIMITS`), into the range the others' values leave."""

    def __init__(self, lobes: list[_Lobe], free: list[_Free]):
        self.lower = np.concatenate([np.full(p.size, p.lower) for p in free])
        self.upper = np.concatenate([np.full(p.size, p.upper) for p in free])
        self.log = np.concatenate([np.full(p.size, _log_scaled(lobes[p.lobe], p)) for p in free])
        offsets = np.cumsum([0] + [p.size for p in free])[:-1]
        self.limits = []
        for p, start in zip(free, offsets, strict=True):
            limit = JOINT_LIMITS.get((lobes[p.lobe].inner.spec_name, p.name))
            if limit is not None:
                entries = np.arange(start, start + p.size)
                self.limits.append((entries, functools.partial(limit, lobes, free, p.lobe)))

    def upper_at(self, x: np.ndarray) -> np.ndarray:
        """The upper ends of the entries given the values ``x`` (joint limits included)."""
        upper = self.upper.copy()
        for entries, limit in self.limits:
            upper[entries] = np.maximum(np.minimum(upper[entries], limit(x)), self.lower[entries])
        return upper

    def values(self, u: np.ndarray) -> np.ndarray:
        """:math:`x = T(u)`."""
        x = constrained(u, self.lower, self.upper, self.log)
        if self.limits:  # the joined entries from the others' values
            upper = self.upper_at(x)
            for entries, _ in self.limits:
                x[entries] = constrained(
                    u[entries], self.lower[entries], upper[entries], self.log[entries]
                )
        return x

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The coordinates of the ranges' ends (:func:`coordinate_bounds`; a joined entry's are
        those of its range as a fraction of the range the others leave, which are the same)."""
        return coordinate_bounds(self.lower, self.upper, self.log)

    def coordinates(self, x: np.ndarray) -> np.ndarray:
        """:math:`u = T^{-1}(x)` (values on or beyond their ends moved inside first)."""
        return unconstrained(x, self.lower, self.upper_at(x), self.log)

    def derivative(self, u: np.ndarray, active: np.ndarray) -> np.ndarray:
        r""":math:`\partial x / \partial u` over the ``active`` entries, ``(P, A)``: central
        differences of :math:`T` (a few arithmetic operations per entry)."""
        columns = np.flatnonzero(active)
        jacobian = np.zeros((u.size, columns.size))
        for c, i in enumerate(columns):
            h = 1e-5 * max(1.0, abs(u[i]))
            up, down = u.copy(), u.copy()
            up[i] += h
            down[i] -= h
            jacobian[:, c] = (self.values(up) - self.values(down)) / (2 * h)
        return jacobian


def _log_scaled(lobe: _Lobe, p: _Free) -> bool:
    """Whether the model declares parameter ``p`` best varied on a log scale
    (:attr:`brdfkit.params.Domain.log`: roughness, exponents)."""
    domain = parameter_domains(type(lobe.inner)).get(p.name)
    return domain is not None and domain.log


def _lafortune_exponent_limit(
    lobes: list[_Lobe], free: list[_Free], k: int, x: np.ndarray
) -> np.ndarray:
    r"""The largest exponents n of Lafortune lobe ``k``'s cosine lobes that keep each peak
    :math:`\max(|C_x|, |C_y|, |C_z|)^n` below half of
    :data:`brdfkit.brdf.lafortune.PEAK_MAX` (the half: room for a Jacobian's step in C),
    given the coefficients in ``x`` (or the lobe's own where they are held)."""
    from brdfkit.brdf.lafortune import PEAK_MAX

    inner = lobes[k].inner
    values = {
        name: np.asarray(getattr(inner, name), dtype=np.float64) for name in ("cx", "cy", "cz")
    }
    start = 0
    for p in free:
        if p.lobe == k and p.name in values:
            values[p.name] = x[start : start + p.size].reshape(values[p.name].shape)
        start += p.size
    largest = np.maximum(
        np.maximum(np.abs(values["cx"]), np.abs(values["cy"])), np.abs(values["cz"])
    )
    largest = largest.reshape(largest.shape[0], -1).max(axis=1)  # per cosine lobe
    with np.errstate(divide="ignore"):
        limit = np.where(largest > 1, math.log(PEAK_MAX / 2) / np.log(largest), np.inf)
    n_shape = np.shape(inner.n)
    return np.broadcast_to(limit.reshape((-1,) + (1,) * (len(n_shape) - 1)), n_shape).ravel()


JOINT_LIMITS = {("lafortune", "n"): _lafortune_exponent_limit}
"""Upper ends that depend on other parameters, by (model, parameter): ``limit(lobes, free, k,
x)`` gives the parameter's upper ends in lobe ``k`` at the values ``x``."""


def _least_squares(
    lobes: tuple[BRDF, ...],
    free: list[_Free],
    robust: _Robust,
    channels: slice,
    max_nfev: int,
    data: MeasuredSamples,
    x0: np.ndarray,
    active: np.ndarray,
    report: Callable[[int], None],
) -> Any:
    """Least squares over the entries of ``x0`` where ``active`` holds (the rest stay put), in
    the unconstrained coordinates of :class:`_Coordinates`: every step is a valid model."""
    from scipy.optimize import least_squares
    from threadpoolctl import threadpool_limits

    coordinates = _Coordinates(lobes, free)
    u0 = coordinates.coordinates(x0)
    u_lower, u_upper = coordinates.bounds()
    model = _LobeValues(lobes, free, data, robust.log_scale)
    calls = [0]

    def full(u_active: np.ndarray) -> np.ndarray:
        u = u0.copy()
        u[active] = u_active
        return u

    def fun(u_active: np.ndarray) -> np.ndarray:
        calls[0] += 1
        report(calls[0])
        total = model.total(model.values(coordinates.values(full(u_active))))
        return model.residuals(total, robust.objective, channels).ravel()

    def jac(u_active: np.ndarray) -> np.ndarray:
        calls[0] += 1
        report(calls[0])
        u = full(u_active)
        x = coordinates.values(u)
        step = coordinates.derivative(u, active)  # (P, A)
        moved = np.flatnonzero(np.any(step != 0, axis=1))
        upper = coordinates.upper_at(x)
        jacobian = model.jacobian(x, moved, coordinates.lower, upper, robust, channels)
        return jacobian @ step[moved]

    with threadpool_limits(_BLAS_THREADS, user_api="blas"):
        result = least_squares(
            fun,
            u0[active],
            jac=jac if _JACOBIAN == "lobes" else _JACOBIAN,
            bounds=(u_lower[active], u_upper[active]),
            method="trf",
            x_scale="jac",
            loss=robust.loss,
            f_scale=robust.f_scale,
            max_nfev=max_nfev,
        )
    result.x, result.calls = coordinates.values(full(result.x)), calls[0]
    return result


def fit(
    measured: BRDF | MeasuredSamples,
    model: str | BRDF,
    *,
    objective: str = "cube_root",
    loss: str = "soft_l1",
    loss_scale: float = 0.5,
    mode: str = "shared",
    starts: int = 4,
    fixed: Collection[str] = (),
    coarse_samples: int = 4000,
    max_samples: int = 30_000,
    max_nfev: int = 60,
    seed: int = 0,
    progress: Progress | None = None,
) -> FitResult:
    """Fit ``model`` to ``measured`` (see the module docstring for the method).

    Parameters
    ----------
    measured : a measured BRDF, any BRDF, or :class:`MeasuredSamples` (see :func:`fit_data`).
    model : a spec string (``"lambertian + cook_torrance"``; parameters written in it stay
        fixed) or a BRDF (a registered model or a sum of them; its values are the first start).
    objective : ``"cube_root"`` (default: the fits look most like the data, see the module
        docstring), ``"log"`` or ``"cosine"`` (Ngan et al. 2005).
    loss : how residuals count (:data:`LOSSES`, scipy's names): ``"soft_l1"`` (default; a
        residual far beyond the scale counts linearly, not quadratically) or ``"linear"``
        (plain least squares), ``"huber"``, ``"cauchy"``, ``"arctan"``.
    loss_scale : the residual at which a robust loss departs from least squares, relative to
        the median size of the measured values on the objective's scale (default ½).
    mode : ``"shared"`` or ``"per_channel"``.
    starts : number of starts, in [1, 1000]: the model's values, then a roughness sweep (random
        points in the bounds for a model without roughness).
    fixed : parameter names to hold (``"alpha"`` in every lobe, ``"1.alpha"`` in lobe 1,
        ``"scale"`` for the factors); each must name a numeric parameter of the model.
    coarse_samples, max_samples : subset sizes for the starts and for the refinement, in
        [10, 10⁸].
    max_nfev : residual evaluations (not counting the Jacobian's) per least-squares run, in
        [1, 10⁶].
    seed : seed of the subsets and random starts, a non-negative integer.
    progress : ``progress(completed, total, description)`` callback (fractional stages).

    Returns
    -------
    FitResult

    Raises
    ------
    brdfkit.errors.ParameterError
        For an argument outside its domain (naming it), an unknown name in ``fixed`` (listing
        the model's parameters), or a model with nothing to fit.
    brdfkit.errors.SpecError
        For a spec string that :func:`brdfkit.brdf.parse` cannot read or that is no sum of
        (optionally scaled) models.

    References
    ----------
    .. [1] A. Ngan, F. Durand, W. Matusik, "Experimental analysis of BRDF models", EGSR 2005.
    .. [2] SciPy, ``scipy.optimize.least_squares``.

    Examples
    --------
    Samples of a known model give its parameters back (GGX, which has no colour parameter of its
    own, gets a fitted factor):

    >>> from brdfkit.brdf import parse
    >>> from brdfkit.measured import MeasuredSamples
    >>> from brdfkit.sampling import hemisphere_pairs
    >>> wi, wo = hemisphere_pairs(2000, seed=1)
    >>> truth = parse("lambertian(rho=0.2) + ggx(alpha=0.3)")
    >>> result = fit(MeasuredSamples(wi, wo, truth.eval(wi, wo)), "lambertian + ggx", starts=1)
    >>> {name: round(value, 6) for name, value in result.params.items()}
    {'0.lambertian.rho': 0.2, '1.ggx.alpha': 0.3, '1.ggx.scale': 1.0}
    >>> result.success, result.errors["relative_l2"] < 1e-8
    (True, True)
    """
    from brdfkit.brdf import parse

    began = time.perf_counter()
    check_choice("objective", objective, OBJECTIVES)
    check_choice("loss", loss, LOSSES)
    if not (_is_number(loss_scale) and 0 < loss_scale < math.inf):
        raise ParameterError(f"loss_scale must be a positive number; got {loss_scale!r:.40}")
    check_choice("mode", mode, MODES)
    for name, value, (least, most) in (
        ("starts", starts, STARTS),
        ("coarse_samples", coarse_samples, SAMPLES),
        ("max_samples", max_samples, SAMPLES),
        ("max_nfev", max_nfev, EVALUATIONS),
        ("seed", seed, (0, 2**63 - 1)),
    ):
        if not _is_integer(value) or not least <= value <= most:
            raise ParameterError(
                f"{name} must be an integer in [{least}, {most}]; got {value!r:.40}"
            )
    if progress is not None and not callable(progress):
        raise ParameterError(f"progress must be a callable or None; got {progress!r:.40}")
    if isinstance(model, str):
        model, explicit = parse(model), _explicit_keywords(model)
    elif isinstance(model, BRDF):
        explicit = [set() for _ in _lobes(model)]
    else:
        raise ParameterError(f"model must be a spec string or a BRDF; got {type(model).__name__}")
    lobes = _without_redundant_diffuse(_lobes(model), explicit)
    _check_fixed(fixed, lobes)
    data = fit_data(measured, seed=seed)
    if data.wi.shape[0] < 10:
        raise ParameterError(f"measured holds {data.wi.shape[0]} valid samples; at least 10 needed")
    channels = data.values.shape[1]
    rng = np.random.default_rng(seed)
    coarse = _subset(data, coarse_samples, rng)
    fine = _subset(data, max_samples, rng)
    groups = [slice(None)] if mode == "shared" else [slice(c, c + 1) for c in range(channels)]
    level = log_scale(data)
    typical = _median_size(_measured_side(data).compressed[objective])
    robust = _Robust(objective, loss, loss_scale * typical, level)
    stages = len(groups) * (2 * starts + 1)
    done = [0]

    def reporter(description: str) -> Callable[[int], None]:
        def report(calls: int) -> None:
            if progress is not None:
                progress(done[0] + min(calls / max_nfev, 1.0), stages, description)

        return report

    fitted, evaluations, cost, success, messages = [], 0, 0.0, True, []
    for g, group in enumerate(groups):
        free = _free_parameters(lobes, explicit, fixed, channels if mode == "shared" else 1)
        if mode == "per_channel" and any(p.size != 1 for p in free):
            raise ParameterError(
                "mode='per_channel' needs single-valued free parameters; "
                f"{[p.name for p in free if p.size != 1]} hold several (fix them or use 'shared')"
            )
        label = "" if mode == "shared" else f" channel {g}"
        everything = np.ones(sum(p.size for p in free), dtype=bool)
        colours = np.concatenate([np.full(p.size, _is_colour(p)) for p in free])
        solve = functools.partial(_least_squares, lobes, free, robust, group, max_nfev)
        best = None
        for s, x0 in enumerate(_starts(free, starts, rng)):
            if colours.any() and not colours.all():  # level the start's colours first
                run = solve(coarse, x0, colours, reporter(f"start {s + 1}{label}: colours"))
                evaluations += run.calls
                x0 = run.x
            done[0] += 1
            run = solve(coarse, x0, everything, reporter(f"start {s + 1}{label}"))
            evaluations += run.calls
            done[0] += 1
            if best is None or run.cost < best.cost:
                best = run
        run = solve(fine, best.x, everything, reporter(f"refine{label}"))
        evaluations += run.calls
        done[0] += 1
        fitted.append((free, run.x))
        cost += float(run.cost)
        success &= bool(run.success)
        messages.append(str(run.message))
    if progress is not None:
        progress(stages, stages, "done")
    if mode == "shared":
        free, x = fitted[0]
    else:  # one value per channel: parameter i of every channel's fit, side by side
        free = [dataclasses.replace(p, size=channels, sequence=True) for p in fitted[0][0]]
        x = np.concatenate([[xs[i] for _, xs in fitted] for i in range(len(free))])
    result_model = _physical(_assemble(lobes, free, x, relax=True))
    params, i = {}, 0
    for p in free:
        values = x[i : i + p.size]
        i += p.size
        key = f"{p.lobe}.{lobes[p.lobe].inner.spec_name}.{p.name}"
        params[key] = float(values[0]) if values.size == 1 else [float(v) for v in values]
    return FitResult(
        model=result_model,
        spec=result_model.to_spec(),
        params=params,
        errors=_errors(result_model, data),
        objective=objective,
        loss=loss,
        loss_scale=robust.f_scale,
        mode=mode,
        cost=cost,
        starts=starts,
        nfev=evaluations,
        samples=int(data.wi.shape[0]),
        fit_samples=int(fine.wi.shape[0]),
        success=success,
        message="; ".join(messages),
        seconds=time.perf_counter() - began,
    )


__all__ = [
    "COLOUR_PARAMETERS",
    "EVALUATIONS",
    "LOSSES",
    "MODES",
    "OBJECTIVES",
    "SAMPLES",
    "STARTS",
    "FitResult",
    "fit",
    "fit_data",
    "fit_errors",
    "log_scale",
    "residuals",
]
