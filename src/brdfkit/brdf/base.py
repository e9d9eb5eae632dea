"""The BRDF protocol, the model registry, and composition (``+``, ``*``).

Conventions (DESIGN.md §1): arguments are *local* unit vectors of shape ``(..., 3)`` with z the
normal; ``wi`` points towards the light, ``wo`` towards the viewer. ``eval`` returns f_r with no
cosine, of shape ``(..., C)``; ``pdf`` is the solid-angle density of :meth:`BRDF.sample`
choosing ``wi`` given ``wo``, of shape ``(...,)``. Parameters broadcast against ``batch + (C,)``,
which gives spatially varying BRDFs for free. Delta lobes contribute nothing to ``eval`` and
``pdf`` and appear only in ``sample``, flagged as delta.

References
----------
.. [1] F. E. Nicodemus et al., "Geometrical considerations and nomenclature for reflectance",
       NBS Monograph 160, 1977.
.. [2] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., ch. 9, 2023.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import math
from collections.abc import Callable, Iterator, MutableMapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from brdfkit._array import (
    Array,
    asarray,
    check_directions,
    constant,
    in_backend_of,
    namespace,
    to_numpy,
)
from brdfkit._checks import check_count, check_memory
from brdfkit.brdf._index import SPEC_NAMES
from brdfkit.errors import ParameterError
from brdfkit.params import (
    UNPHYSICAL_MAX,
    Domain,
    channel_count,
    check_choice,
    check_domains,
    check_flag,
    described,
    param,
    parameter_domains,
)


class Registry(MutableMapping[str, "type[BRDF]"]):
    """Model classes by their spec name, each model's module imported the first time its
    name is looked up (:data:`brdfkit.brdf._index.SPEC_NAMES` says which), and every one
    of them when the registry is listed: a process that renders one model imports that
    model's module and not the other two dozen."""

    def __init__(self) -> None:
        self._models: dict[str, type[BRDF]] = {}

    def __getitem__(self, name: str) -> type[BRDF]:
        if name not in self._models:
            module = SPEC_NAMES.get(name)
            if module is not None:
                importlib.import_module(f"brdfkit.brdf.{module}")
        return self._models[name]

    def __setitem__(self, name: str, cls: type[BRDF]) -> None:
        self._models[name] = cls

    def __delitem__(self, name: str) -> None:
        del self._models[name]

    def __iter__(self) -> Iterator[str]:
        self._import_all()
        return iter(self._models)

    def __len__(self) -> int:
        self._import_all()
        return len(self._models)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({dict(self)!r})"

    def add(self, name: str, cls: type[BRDF]) -> None:
        """Register ``cls`` under ``name``, refusing a name another class holds."""
        if self._models.get(name, cls) is not cls:
            raise ValueError(f"model name {name!r} is registered twice")
        self._models[name] = cls

    def _import_all(self) -> None:
        for module in sorted(set(SPEC_NAMES.values())):
            importlib.import_module(f"brdfkit.brdf.{module}")


MODELS = Registry()
"""Registered model classes by their spec name (``"lambertian"``, ``"ggx"``, …)."""


def register(name: str) -> Callable[[type[BRDF]], type[BRDF]]:
    """Class decorator: make a model known to the spec parser and the CLI under ``name``."""

    def decorate(cls: type[BRDF]) -> type[BRDF]:
        MODELS.add(name, cls)
        cls.spec_name = name
        return cls

    return decorate


MAX_ALBEDO_SAMPLES = 1 << 24
"""Most Monte Carlo samples per direction :meth:`BRDF.albedo_estimate` takes (its standard
error is then below 3·10⁻⁴ of a unit albedo's spread)."""

HEMISPHERES = ("upper", "both")
"""What :meth:`BRDF.albedo_estimate` integrates over: reflection only, or reflection and
transmission."""


ALBEDO = Domain(0.0, 1.0, hint="an albedo", unphysical_hi=UNPHYSICAL_MAX)
"""Albedos and reflectances (ρ, k_d, k_s, ``diffuse``, ``reflectance``, f0): [0, 1]."""


ROUGHNESS = Domain(1e-4, 10.0, hint="microfacet roughness α", log=True)
"""Microfacet roughness α (GGX, Beckmann; Cook–Torrance's m): [10⁻⁴, 10]. At 10⁻⁴ the lobe is a
mirror to 0.006°; at 10 facets slope at 84° on average; in between D, Λ and the samplers stay
finite in float32."""


EXPONENT = Domain(0.0, 1e6, hint="cosine exponent", log=True)
"""Cosine-lobe exponents n (Phong, Blinn–Phong, Lafortune): [0, 10⁶], a lobe 0.1° wide at the
top end."""


SCALE = Domain(0.0, UNPHYSICAL_MAX, hint="the factor of k * model")
"""The factor ``k`` of :class:`Scaled`: [0, 10⁶]."""


def check_brdf(name: str, value: Any) -> BRDF:
    """Raise :class:`~brdfkit.errors.ParameterError` unless ``value`` is a :class:`BRDF`."""
    if not isinstance(value, BRDF):
        raise ParameterError(f"{name} must be a BRDF; got {described(value)}")
    return value


def check_hemisphere(hemisphere: str) -> str:
    """Raise :class:`~brdfkit.errors.ParameterError` unless ``hemisphere`` is one of
    :data:`HEMISPHERES`."""
    return check_choice("hemisphere", hemisphere, HEMISPHERES)


def _broadcast_rows(w: Any) -> np.ndarray | None:
    """``w`` ``(..., 3)`` with each batch axis along which it is broadcast (a NumPy stride of
    0, length > 1) cut to length 1, or ``None`` where there is none (or ``w`` is not a
    NumPy array)."""
    if type(w) is not np.ndarray or w.ndim < 2:
        return None
    index = tuple(
        slice(0, 1) if stride == 0 and n > 1 else slice(None)
        for stride, n in zip(w.strides[:-1], w.shape[:-1], strict=True)
    )
    if all(i == slice(None) for i in index):
        return None
    return w[index]


def _broadcast_back(value: Any, rows: tuple[int, ...], batch: tuple[int, ...]) -> Any:
    """A result computed on the cut directions (batch ``rows``) broadcast to the full ``batch``:
    an array ``rows`` (per direction) or ``rows + (C,)`` (per direction and channel), or a
    list or tuple of them; ``None`` where a result has another shape (a model parameter that
    varies over the batch gave it the batch's extent)."""
    if isinstance(value, list | tuple):
        parts = [_broadcast_back(v, rows, batch) for v in value]
        return None if any(part is None for part in parts) else type(value)(parts)
    if type(value) is not np.ndarray or value.shape[: len(rows)] != rows:
        return None
    if value.ndim == len(rows):
        return np.broadcast_to(value, batch)
    if value.ndim == len(rows) + 1:
        return np.broadcast_to(value, (*batch, value.shape[-1]))
    return None


def per_direction(method: Callable[[Any, Array], Any]) -> Callable[[Any, Array], Any]:
    """Decorate a method ``(self, w)`` whose results (an array ``(...,)`` or ``(..., C)``,
    or a list or tuple of them) depend on each direction of ``w`` ``(..., 3)`` and on the
    model's parameters alone.

    Where ``w`` is a NumPy array broadcast along batch axes (stride 0: the fixed ωo of a
    sampler's χ² test and pointwise checks, of an albedo estimate's samples, of a pixel's
    samples), the method runs on one direction per such axis and its results are broadcast
    back (read-only views): the same values, from one evaluation per direction instead of
    one per sample. Any other ``w`` (a contiguous batch, another array backend, a trace)
    goes through as is, and so does one whose results do not come out per direction (a
    parameter varying over the batch): the method then runs again on the whole ``w``.
    """

    @functools.wraps(method)
    def wrapper(self: Any, w: Array) -> Any:
        rows = _broadcast_rows(w)
        if rows is None:
            return method(self, w)
        value = _broadcast_back(method(self, rows), rows.shape[:-1], w.shape[:-1])
        return method(self, w) if value is None else value

    return wrapper


def normalized_weights(weights: list[Array]) -> list[Array]:
    """Weights ≥ 0 scaled to sum to 1 (equal probabilities where all are 0).

    The lobe-choice probabilities of a one-sample mixture (:class:`Sum`, and the models that
    sample a mixture of lobes).
    """
    xp = namespace(*weights)
    weights = [xp.maximum(w, xp.zeros_like(w)) for w in weights]
    total = weights[0]
    for w in weights[1:]:
        total = total + w
    positive = total > 0
    safe_total = xp.where(positive, total, xp.ones_like(total))
    uniform = constant(1.0 / len(weights), total)
    return [xp.where(positive, w / safe_total, uniform) for w in weights]


def mixture_choices(probabilities: list[Array], u: Array) -> list[tuple[Array, Array]]:
    """The one-sample choice of a mixture component by the first uniform.

    Component k takes ``u[..., 0]`` in ``[P_k, P_k + p_k)`` (the last one up to 1), with
    ``P_k`` the sum of the probabilities before it. Returns, per component, ``(pick, u_k)``:
    whether it was chosen, ``(...,)``, and ``u`` with ``u[..., 0]`` re-stretched to [0, 1)
    inside that interval, so that one set of uniforms serves both the choice and the component.

    References
    ----------
    .. [1] E. Veach, *Robust Monte Carlo methods for light transport simulation*, PhD thesis,
           Stanford, 1997, §9.2.4.
    """
    xp = namespace(u, *probabilities)
    u0 = u[..., 0]
    rest = [u[..., j] for j in range(1, u.shape[-1])]
    lo = xp.zeros_like(u0)
    choices = []
    for k, p in enumerate(probabilities):
        last = k == len(probabilities) - 1
        hi = xp.ones_like(lo) if last else lo + p
        pick = u0 >= lo if last else (u0 >= lo) & (u0 < hi)
        span = xp.where(p > 0, p, xp.ones_like(p))
        stretched = xp.clip((u0 - lo) / span, 0.0, 1.0 - 1e-7)
        choices.append((pick, xp.stack([stretched, *rest], axis=-1)))
        lo = hi
    return choices


# --------------------------------------------------------------------------- samples
@dataclass(frozen=True, eq=False)
class Sample:
    """One importance sample per batch element.

    Attributes
    ----------
    wi : (..., 3) sampled direction towards the light (below the surface for transmission).
    weight : (..., C) Monte Carlo throughput ``f·|cos θi| / pdf`` (for delta lobes, the lobe's
        reflectance); 0 where sampling failed.
    pdf : (...,) solid-angle density of ``wi`` (0 for a delta lobe or a failed sample).
    delta : (...,) bool, whether ``wi`` came from a delta lobe.
    """

    wi: Array
    weight: Array
    pdf: Array
    delta: Array


# --------------------------------------------------------------------------- the protocol
class BRDF:
    r"""Base class of every reflectance model: the protocol of DESIGN.md §3 and composition.

    A model is a frozen dataclass (``@dataclass(frozen=True, eq=False)``) that declares its
    parameters (fields, with their :attr:`domains` and :attr:`choices`) and writes its paper's
    formulas in the hooks :meth:`_eval`, :meth:`_pdf` and :meth:`_sample` (and :meth:`_albedo`,
    :meth:`_sampling_weight` where it has closed forms). The public methods apply the
    conventions once, as SciPy's ``rv_continuous.pdf`` validates, broadcasts and masks around a
    distribution's ``_pdf``:

    - construction validates every parameter against its declared domain or choices and sets
      :attr:`channels` (:meth:`__post_init__`);
    - a model that does not :attr:`transmit <transmits>` is one-sided: ``eval`` and ``pdf`` are
      0 where ``wi.z <= 0`` or ``wo.z <= 0``, and ``sample``, the albedo and the sampling
      weight are 0 where ``wo.z <= 0``; a transmitting model (a BSDF) handles both sides in
      its hooks;
    - results are broadcast to ``batch + (C,)`` (``(...,)`` for densities) in the namespace and
      dtype of the directions;
    - a sample whose density is 0 and that is no delta has failed: its weight is 0.

    The hooks see every lane, masked ones included: where a formula would give NaN or ∞ on a
    lane the public method then zeroes (a direction below the surface, a grazing one), the hook
    guards it, so that gradients through ``where`` stay finite (PyTorch, JAX). A model that
    wants full control (measured data, composition) overrides the public methods instead.
    Class attributes state the physics a model claims, and the property tests prove it.
    """

    spec_name: ClassVar[str] = ""
    spec_aliases: ClassVar[dict[str, str]] = {}
    """Alternative parameter names that spec strings accept (``{"albedo": "rho"}``)."""
    domains: ClassVar[dict[str, Domain]] = {}
    """The :class:`Domain` of each numeric parameter declared by this class (``{"alpha":
    ROUGHNESS}``); :func:`parameter_domains` merges those of the bases, and
    :func:`check_domains` validates against them."""
    choices: ClassVar[dict[str, tuple[str, ...]]] = {}
    """The options of each string parameter declared by this class (``{"model":
    ("qualitative", "full")}``), merged with those of the bases."""
    reciprocal: ClassVar[bool] = True
    """Whether f(wi, wo) = f(wo, wi) for every parameter value (Helmholtz reciprocity)."""
    energy_conserving: ClassVar[bool] = True
    """Whether the directional albedo is ≤ 1 for every valid parameter value."""
    isotropic: ClassVar[bool] = True
    """Whether f is invariant under rotation about the normal (for the default parameters)."""
    has_delta: ClassVar[bool] = False
    """Whether the model has delta lobes (which ``eval``/``pdf`` do not see)."""
    transmits: ClassVar[bool] = False
    """Whether the model is a BSDF that also scatters into the lower hemisphere."""

    channels: int = 1

    # -- construction -----------------------------------------------------------------------
    def __post_init__(self) -> None:
        """Validate the parameters once and set :attr:`channels`.

        Every numeric parameter is checked against its declared domain
        (:func:`~brdfkit.params.check_domains`), every string parameter against its
        :attr:`choices`, every ``bool`` field for being a bool; :attr:`channels` is the count
        the channel-valued parameters imply (:meth:`_channel_values`; a model with none keeps
        its class's). A model that has conditions of its own (ρd + ρs ≤ 1) or derived
        quantities extends this method, calling it first.

        Raises
        ------
        brdfkit.errors.ParameterError
            Naming the first parameter that is invalid, its value and what is allowed.
        """
        check_domains(self)
        declared: dict[str, tuple[str, ...]] = {}
        for klass in reversed(type(self).__mro__):
            declared.update(vars(klass).get("choices", {}))
        for name, options in declared.items():
            check_choice(name, getattr(self, name), options)
        for field in dataclasses.fields(self):  # type: ignore[arg-type]
            if field.type in ("bool", bool):
                check_flag(field.name, getattr(self, field.name))
        values = self._channel_values()
        if values:  # else the class's own channels stand (a measured table, a fixed count)
            object.__setattr__(
                self, "channels", channel_count(*values.values(), names=tuple(values))
            )

    def _channel_values(self) -> dict[str, Any]:
        """The channel-valued parameters by name, whose trailing axes give :attr:`channels`:
        by default every numeric parameter with a declared domain that is not ``None``."""
        return {
            name: getattr(self, name)
            for name in parameter_domains(type(self))
            if getattr(self, name) is not None
        }

    def _directions(self, **named: Array) -> tuple[Array, ...]:
        """The arguments ``named`` (directions, and ``u``) checked (last axis 3 for the
        directions) and put in the backend of the model's parameters and theirs
        (:func:`~brdfkit._array.in_backend_of`: NumPy directions for torch parameters compute
        in torch)."""
        check_directions(**{k: v for k, v in named.items() if k != "u"})
        values = [v for v in self.params().values() if hasattr(v, "shape")]  # arrays only
        return in_backend_of(values, *named.values())

    # -- the four methods -------------------------------------------------------------------
    def eval(self, wi: Array, wo: Array) -> Array:
        """f_r(wi, wo), no cosine; shape ``(..., C)``: :meth:`_eval` on the model's side(s)
        of the surface, 0 elsewhere."""
        wi, wo = self._directions(wi=wi, wo=wo)
        value = broadcast_to_shape(self._eval(wi, wo), (*result_shape(wi, wo), self.channels))
        if self.transmits:
            return value
        return zero_unless(upper_hemisphere(wi, wo), value)

    def pdf(self, wi: Array, wo: Array) -> Array:
        """Solid-angle pdf of :meth:`sample` choosing ``wi`` given ``wo``; shape ``(...,)``:
        :meth:`_pdf` on the model's side(s) of the surface, 0 elsewhere."""
        wi, wo = self._directions(wi=wi, wo=wo)
        value = self._pdf(wi, wo)
        if not self.transmits:
            value = zero_unless(upper_hemisphere(wi, wo)[..., 0], value)
        return broadcast_to_shape(value, result_shape(wi, wo))

    def sample(self, wo: Array, u: Array) -> Sample:
        """Importance-sample ``wi`` given ``wo`` from uniforms ``u`` of shape ``(..., 2)``
        (``(..., 3)`` for the models that choose between reflection and refraction):
        :meth:`_sample`, with weight and pdf 0 where it failed (pdf 0 and no delta) or, for a
        one-sided model, where ``wo`` is not above the surface."""
        wo, u = self._directions(wo=wo, u=u)
        s = self._sample(wo, u)
        xp = namespace(wo, s.weight, s.pdf)
        batch = np.broadcast_shapes(wo.shape[:-1], u.shape[:-1], s.wi.shape[:-1])
        delta = (
            s.delta if hasattr(s.delta, "shape") else xp.full_like(s.pdf, s.delta, dtype=xp.bool)
        )
        ok = (s.pdf > 0) | delta
        if not self.transmits:
            ok = ok & (wo[..., 2] > 0)
        weight = broadcast_to_shape(s.weight, (*batch, self.channels))
        return Sample(
            s.wi,
            zero_unless(ok[..., None], weight),
            broadcast_to_shape(zero_unless(ok, s.pdf), batch),
            broadcast_to_shape(delta, batch),
        )

    def albedo(self, wo: Array, samples: int = 4096, seed: int = 0) -> Array:
        """Directional-hemispherical reflectance ρ(wo) = ∫ f(wi, wo) cos θi dωi, ``(..., C)``.

        The closed form :meth:`_albedo` where the model has one; else a Monte Carlo estimate
        with ``samples`` scrambled-Sobol importance samples per direction
        (:meth:`albedo_estimate` gives its standard error); only reflected samples
        (``wi.z > 0``) count.
        """
        return self.albedo_estimate(wo, samples=samples, seed=seed)[0]

    def albedo_estimate(
        self, wo: Array, samples: int = 4096, seed: int = 0, hemisphere: str = "upper"
    ) -> tuple[Array, Array]:
        r"""The albedo ``(mean, standard_error)``, both ``(..., C)``.

        Where the model has a closed form (:meth:`_albedo`), that with zero error (``samples``
        and ``seed`` unused; ``samples`` is checked all the same: an integer from 1 to
        :data:`MAX_ALBEDO_SAMPLES`, else :class:`~brdfkit.errors.ParameterError`, or
        :class:`~brdfkit.errors.ResourceError` above it or beyond the memory available).
        Otherwise the mean of the sample weights :math:`f|\cos\theta_i|/p` over ``samples``
        scrambled-Sobol points per direction.
        ``hemisphere="upper"`` counts the reflected samples only (``wi.z > 0``):
        :math:`\int_{H^2_+} f\cos\theta_i\,d\omega_i`; ``"both"`` counts every sample, adding a
        BSDF's transmittance: :math:`\int_{S^2} f|\cos\theta_i|\,d\omega_i`.

        References
        ----------
        .. [1] M. Pharr, W. Jakob, G. Humphreys, *Physically Based Rendering*, 4th ed., §4.3
           (hemispherical-directional reflectance) and §2.1.3 (Monte Carlo estimator).
        """
        check_hemisphere(hemisphere)
        (wo,) = self._directions(wo=wo)
        samples = check_count("samples", samples, MAX_ALBEDO_SAMPLES)
        exact = self._albedo(wo, hemisphere)
        if exact is not None:
            if not self.transmits:
                exact = zero_unless(wo[..., 2:3] > 0, exact)
            exact = broadcast_to_shape(exact, (*wo.shape[:-1], self.channels))
            return exact, namespace(exact).zeros_like(exact)
        return self._albedo_monte_carlo(wo, samples, seed, hemisphere)

    def _albedo_monte_carlo(
        self, wo: Array, samples: int, seed: int, hemisphere: str
    ) -> tuple[Array, Array]:
        """:meth:`albedo_estimate` by Monte Carlo: the mean weight and its standard error."""
        from scipy.stats import qmc

        xp = namespace(wo)
        wo = asarray(wo, xp)
        values = math.prod(wo.shape[:-1]) * samples * (self.channels + 6)
        check_memory(f"the albedo of {math.prod(wo.shape[:-1])} directions", 8 * 4 * values)
        u_np = qmc.Sobol(d=3, scramble=True, seed=seed).random(samples)
        u = asarray(u_np, xp, like=wo)
        batch = wo.shape[:-1]
        wo_b = xp.broadcast_to(wo[..., None, :], (*batch, samples, 3))
        u_b = xp.broadcast_to(u, (*batch, samples, 3))
        s = self.sample(wo_b, u_b)
        w = s.weight
        if hemisphere == "upper":
            w = xp.where((s.wi[..., 2] > 0)[..., None], w, xp.zeros_like(w))
        mean = xp.mean(w, axis=-2)
        var = xp.mean(w * w, axis=-2) - mean * mean
        stderr = xp.sqrt(xp.maximum(var, xp.zeros_like(var)) / samples)
        return mean, stderr

    def sampling_weight(self, wo: Array) -> Array:
        """A cheap estimate of this lobe's albedo at ``wo`` (grey, ``(...,)``), ≥ 0.

        A sum of lobes chooses which lobe to sample in proportion to it: :meth:`_sampling_weight`,
        0 where a one-sided model's ``wo`` is not above the surface.
        """
        value = self._sampling_weight(wo)
        if not self.transmits:
            value = zero_unless(wo[..., 2] > 0, value)
        return broadcast_to_shape(value, wo.shape[:-1])

    # -- the hooks ----------------------------------------------------------------------------
    def _eval(self, wi: Array, wo: Array) -> Array:
        """The model's f_r, broadcastable to ``(..., C)``; :meth:`eval` masks and broadcasts."""
        raise NotImplementedError

    def _pdf(self, wi: Array, wo: Array) -> Array:
        """The density of :meth:`_sample`, broadcastable to ``(...,)``; :meth:`pdf` masks."""
        raise NotImplementedError

    def _sample(self, wo: Array, u: Array) -> Sample:
        """A sample per batch element; :meth:`sample` zeroes the failed ones and broadcasts.
        ``weight`` may be a per-channel constant and ``delta`` a Python bool."""
        raise NotImplementedError

    def _albedo(self, wo: Array, hemisphere: str) -> Array | None:
        """The albedo in closed form, broadcastable to ``(..., C)``, or ``None`` (the default:
        estimated by Monte Carlo). ``hemisphere`` as in :meth:`albedo_estimate`."""
        return None

    def _sampling_weight(self, wo: Array) -> Array:
        """The sampling weight before masking; the default is a 64-sample Monte Carlo albedo."""
        xp = namespace(wo)
        return xp.mean(self.albedo(wo, samples=64), axis=-1)

    # -- description ------------------------------------------------------------------------
    @classmethod
    def examples(cls) -> list[BRDF]:
        """Representative instances (a sweep of valid parameters) for tests, checks and the atlas.

        Models override this with a handful of settings that span their parameter ranges.
        """
        return [cls()]

    def params(self) -> dict[str, Any]:
        """The model's parameters by name (dataclass fields)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}  # type: ignore[arg-type]

    def to_spec(self) -> str:
        """This model as a spec string that :func:`brdfkit.brdf.parse` reads back."""
        args = ", ".join(f"{k}={spec_value(v)}" for k, v in self.params().items())
        return f"{self.spec_name}({args})"

    def __repr__(self) -> str:
        return self.to_spec()

    # -- composition ------------------------------------------------------------------------
    def __add__(self, other: BRDF) -> BRDF:
        if not isinstance(other, BRDF):
            return NotImplemented
        left = self.lobes if isinstance(self, Sum) else (self,)
        right = other.lobes if isinstance(other, Sum) else (other,)
        return Sum((*left, *right))

    def __mul__(self, k: Any) -> BRDF:
        if isinstance(k, BRDF):
            return NotImplemented
        return Scaled(k, self)

    __rmul__ = __mul__


def spec_value(v: Any) -> str:
    """A parameter value as the spec grammar writes it: a string quoted, a number in the
    shortest form that reads back to the same float, a per-channel value as ``[a, b, c]``.

    Raises
    ------
    ValueError
        For a spatially varying value (it has no spec-string form).
    """
    if isinstance(v, str):
        return repr(v)
    if isinstance(v, bool):
        return str(v)
    arr = to_numpy(v)
    if arr.ndim == 0:
        return repr(float(arr))  # the shortest string that reads back to the same float
    if arr.ndim == 1:
        return "[" + ", ".join(repr(float(x)) for x in arr) + "]"
    raise ValueError("a spatially varying parameter has no spec-string form")


def broadcast_channels(value: Array, batch: tuple[int, ...], channels: int) -> Array:
    """``value`` broadcast to ``batch + (channels,)``."""
    xp = namespace(value)
    return xp.broadcast_to(value, (*batch, channels))


def result_shape(*arrays: Array) -> tuple[int, ...]:
    """Broadcast batch shape of direction arrays (their last axis dropped)."""
    return tuple(np.broadcast_shapes(*(tuple(a.shape[:-1]) for a in arrays)))


def upper_hemisphere(wi: Array, wo: Array) -> Array:
    """``(..., 1)`` bool mask: both directions strictly above the surface."""
    return ((wi[..., 2] > 0) & (wo[..., 2] > 0))[..., None]


def zero_unless(condition: Array, value: Array) -> Array:
    """``value`` where ``condition`` holds, else 0 (the two broadcast together).

    A NumPy ``value`` that has the joint shape already is copied (keeping its memory layout)
    and zeroed in place: the same values as ``where`` with no array of zeros to make.
    """
    if type(value) is np.ndarray and isinstance(condition, np.ndarray | np.bool_):
        if value.shape == np.broadcast_shapes(np.shape(condition), value.shape):
            out = value.copy(order="K")
            np.copyto(out, 0, where=np.logical_not(condition))
            return out
    xp = namespace(condition, value)
    return xp.where(condition, value, xp.zeros_like(value))


def positive_or_one(x: Array) -> Array:
    """``x`` where it is > 0, else 1: a divisor or a base of a power that stays finite (and
    keeps gradients finite) on the lanes the public methods zero."""
    xp = namespace(x)
    return xp.where(x > 0, x, xp.ones_like(x))


def broadcast_to_shape(value: Array, shape: tuple[int, ...]) -> Array:
    """``value`` broadcast against ``shape`` (``value`` itself where that changes nothing); a
    parameter that varies over the batch may give ``value`` axes of its own."""
    target = np.broadcast_shapes(tuple(value.shape), shape)
    if tuple(value.shape) == target:
        return value
    return namespace(value).broadcast_to(value, target)


# --------------------------------------------------------------------------- composition
@dataclass(frozen=True, eq=False)
class Sum(BRDF):
    """The sum of lobes, e.g. the dichromatic model ``Lambertian(...) + CookTorrance(...)``.

    ``eval`` adds the lobes. ``sample`` picks lobe k with probability proportional to its
    :meth:`BRDF.sampling_weight` (an albedo estimate) at ``wo``, using the first uniform for the
    choice and re-stretching it for the lobe, so that two uniforms suffice; ``pdf`` is the
    matching mixture of the non-delta lobes' densities (one-sample MIS with the balance
    heuristic, Veach 1997 §9.2.4).

    Reciprocal / energy-conserving exactly when every lobe is and (for energy) when the lobes'
    albedos add to ≤ 1, which the property checks measure.
    """

    lobes: tuple[BRDF, ...]

    def __post_init__(self) -> None:
        if not isinstance(self.lobes, tuple) or len(self.lobes) < 1:
            raise ParameterError(
                f"lobes must be a non-empty tuple of BRDFs; got {described(self.lobes)}"
            )
        for i, lobe in enumerate(self.lobes):
            check_brdf(f"lobes[{i}]", lobe)
        counts = {lobe.channels for lobe in self.lobes} - {1}
        if len(counts) > 1:
            raise ParameterError(
                f"lobes must share a channel count (or have 1); got {sorted(counts)}"
            )

    @property
    def channels(self) -> int:  # type: ignore[override]
        return max(lobe.channels for lobe in self.lobes)

    @property
    def reciprocal(self) -> bool:  # type: ignore[override]
        return all(lobe.reciprocal for lobe in self.lobes)

    @property
    def energy_conserving(self) -> bool:  # type: ignore[override]
        return False  # holds only if the albedos add to ≤ 1: measured, not claimed

    @property
    def isotropic(self) -> bool:  # type: ignore[override]
        return all(lobe.isotropic for lobe in self.lobes)

    @property
    def has_delta(self) -> bool:  # type: ignore[override]
        return any(lobe.has_delta for lobe in self.lobes)

    @property
    def transmits(self) -> bool:  # type: ignore[override]
        return any(lobe.transmits for lobe in self.lobes)

    def eval(self, wi: Array, wo: Array) -> Array:
        total = self.lobes[0].eval(wi, wo)
        for lobe in self.lobes[1:]:
            total = total + lobe.eval(wi, wo)
        return total

    def _probabilities(self, wo: Array) -> list[Array]:
        xp = namespace(wo)
        zero = xp.zeros_like(wo[..., 0])  # broadcasts every weight to wo's batch
        return normalized_weights(
            [xp.maximum(lobe.sampling_weight(wo), zero) for lobe in self.lobes]
        )

    def pdf(self, wi: Array, wo: Array) -> Array:
        probs = self._probabilities(wo)
        total = None
        for p, lobe in zip(probs, self.lobes, strict=True):
            term = p * lobe.pdf(wi, wo)
            total = term if total is None else total + term
        return total

    def sample(self, wo: Array, u: Array) -> Sample:
        xp = namespace(wo, u)
        u = asarray(u, xp, like=wo)  # NumPy uniforms with torch directions compute in torch
        probs = self._probabilities(wo)
        chosen_wi = chosen_w = chosen_delta = None
        chosen_pdf = None
        choices = mixture_choices(probs, u)
        for p, lobe, (pick, u_k) in zip(probs, self.lobes, choices, strict=True):
            s = lobe.sample(wo, u_k)
            p_safe = xp.where(p > 0, p, xp.ones_like(p))
            delta_w = s.weight / p_safe[..., None]
            if chosen_wi is None:
                chosen_wi, chosen_w = s.wi, delta_w
                chosen_delta, chosen_pdf = s.delta, s.pdf * p
            else:
                chosen_wi = xp.where(pick[..., None], s.wi, chosen_wi)
                chosen_w = xp.where(pick[..., None], delta_w, chosen_w)
                chosen_delta = xp.where(pick, s.delta, chosen_delta)
                chosen_pdf = xp.where(pick, s.pdf * p, chosen_pdf)
        # Non-delta picks: the mixture density and the full f give the MIS-balanced weight.
        mix_pdf = self.pdf(chosen_wi, wo)
        f = self.eval(chosen_wi, wo)
        cos_theta_i = xp.abs(chosen_wi[..., 2])
        # A sample its own lobe rejected (pdf 0) stays failed, and so does one whose mixture
        # density is denormal (a far tail: f·cos/pdf would overflow).
        ok = (mix_pdf > xp.finfo(mix_pdf.dtype).smallest_normal) & (chosen_pdf > 0) & ~chosen_delta
        safe_pdf = xp.where(ok, mix_pdf, xp.ones_like(mix_pdf))
        smooth_w = xp.where(
            ok[..., None], f * (cos_theta_i / safe_pdf)[..., None], xp.zeros_like(f)
        )
        weight = xp.where(chosen_delta[..., None], chosen_w, smooth_w)
        pdf = xp.where(chosen_delta, chosen_pdf, xp.where(ok, mix_pdf, xp.zeros_like(mix_pdf)))
        return Sample(chosen_wi, weight, pdf, chosen_delta)

    def albedo(self, wo: Array, samples: int = 4096, seed: int = 0) -> Array:
        total = self.lobes[0].albedo(wo, samples=samples, seed=seed)
        for lobe in self.lobes[1:]:
            total = total + lobe.albedo(wo, samples=samples, seed=seed)
        return total

    def sampling_weight(self, wo: Array) -> Array:
        total = self.lobes[0].sampling_weight(wo)
        for lobe in self.lobes[1:]:
            total = total + lobe.sampling_weight(wo)
        return total

    def params(self) -> dict[str, Any]:
        return {"lobes": self.lobes}

    def to_spec(self) -> str:
        return " + ".join(lobe.to_spec() for lobe in self.lobes)


@dataclass(frozen=True, eq=False)
class Scaled(BRDF):
    """``k * brdf``: every value and sample weight multiplied by ``k`` (scalar or per channel),
    k ∈ [0, 10⁶] (:data:`SCALE`).

    Reciprocal when the inner model is; energy-conserving only when measured so (k may be > 1).
    """

    k: Any
    inner: BRDF

    def __post_init__(self) -> None:
        check_brdf("inner", self.inner)
        SCALE.check("k", self.k)
        channel_count(self.k, np.zeros(self.inner.channels), names=("k", "inner model"))

    @property
    def channels(self) -> int:  # type: ignore[override]
        return channel_count(self.k, np.zeros(self.inner.channels))

    @property
    def reciprocal(self) -> bool:  # type: ignore[override]
        return self.inner.reciprocal

    @property
    def energy_conserving(self) -> bool:  # type: ignore[override]
        return self.inner.energy_conserving and bool(np.all(to_numpy(self.k) <= 1))

    @property
    def isotropic(self) -> bool:  # type: ignore[override]
        return self.inner.isotropic

    @property
    def has_delta(self) -> bool:  # type: ignore[override]
        return self.inner.has_delta

    @property
    def transmits(self) -> bool:  # type: ignore[override]
        return self.inner.transmits

    def eval(self, wi: Array, wo: Array) -> Array:
        return param(self.k, wi) * self.inner.eval(wi, wo)

    def pdf(self, wi: Array, wo: Array) -> Array:
        return self.inner.pdf(wi, wo)

    def sample(self, wo: Array, u: Array) -> Sample:
        s = self.inner.sample(wo, u)
        return Sample(s.wi, param(self.k, wo) * s.weight, s.pdf, s.delta)

    def albedo(self, wo: Array, samples: int = 4096, seed: int = 0) -> Array:
        return param(self.k, wo) * self.inner.albedo(wo, samples=samples, seed=seed)

    def sampling_weight(self, wo: Array) -> Array:
        xp = namespace(wo)
        return xp.mean(param(self.k, wo), axis=-1) * self.inner.sampling_weight(wo)

    def params(self) -> dict[str, Any]:
        return {"k": self.k, "inner": self.inner}

    def to_spec(self) -> str:
        inner = self.inner.to_spec()
        if isinstance(self.inner, Sum):
            inner = f"({inner})"
        return f"{spec_value(self.k)} * {inner}"


__all__ = [
    "ALBEDO",
    "BRDF",
    "EXPONENT",
    "HEMISPHERES",
    "MAX_ALBEDO_SAMPLES",
    "MODELS",
    "ROUGHNESS",
    "SCALE",
    "Registry",
    "Sample",
    "Scaled",
    "Sum",
    "broadcast_channels",
    "broadcast_to_shape",
    "check_brdf",
    "check_hemisphere",
    "mixture_choices",
    "normalized_weights",
    "positive_or_one",
    "register",
    "result_shape",
    "spec_value",
    "upper_hemisphere",
    "zero_unless",
]
