r"""A BRDF whose ``eval``, ``pdf`` and ``sample`` run as kernels compiled from its own code.

:func:`compile` wraps a model in a :class:`CompiledBRDF`. Each method's kernel is traced and
compiled (:func:`brdfkit.compiled.kernel.compile_traced`) for the model's *structure*
(:mod:`brdfkit.compiled.structure`: its spec tree without the parameter values), which takes
the values as an input: a model that differs in values only reuses the kernel, neither
traced nor compiled again, in this process or (from the disk cache) in the next. A structure
whose constructor needs concrete values (it branches on one in Python) has its values baked
into its kernels instead, one build per parameter set; the cache records which structures
do, so that the failed abstract trace is paid once per machine.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from brdfkit._array import Array, namespace
from brdfkit.brdf.base import BRDF, Sample
from brdfkit.compiled import cache as kernel_cache
from brdfkit.compiled import structure as _structure
from brdfkit.compiled.chunked import DEFAULT_CHUNK, directions
from brdfkit.compiled.jit import vector_bits
from brdfkit.compiled.kernel import RECORDS, Kernel, compile_traced, machine_code_cached

_STRUCTURAL: dict[tuple[Any, ...], Any] = {}
"""Kernels by model structure, dtype, method and vector width (the values are inputs), or
:data:`_BAKED` for structures whose constructor needs concrete values."""
_BAKED = object()
_STRUCTURAL_LOCK = threading.Lock()


def _record_key(structural_key: tuple[Any, ...]) -> str:
    """The :mod:`brdfkit.compiled.cache` key of a model structure's generated kernel (its repr
    holds classes, options and shapes only: the same in every process)."""
    return kernel_cache.key("structure", repr(structural_key))


def _known_baked(structural_key: tuple[Any, ...]) -> bool:
    """Whether the disk cache records that this structure's constructor needs concrete values
    (its trace with abstract ones failed in an earlier process)."""
    stored = kernel_cache.load_record(RECORDS, _record_key(structural_key))
    return stored is not None and bool(stored.get("baked"))


def _method(model: BRDF, method: str) -> Callable[..., Any]:
    """The array function of ``model`` that the kernel of ``method`` computes."""
    if method == "eval":
        return model.eval
    if method == "pdf":
        return model.pdf
    if method == "sample":

        def sample(wo: Array, u: Array) -> tuple[Array, Array, Array, Array]:
            s = model.sample(wo, u)
            return s.wi, s.weight, s.pdf, s.delta

        return sample
    if method == "albedo":  # the albedo's terms: only the weights of samples above the surface

        def albedo_term(wo: Array, u: Array) -> tuple[Array]:
            xp = namespace(wo, u)
            s = model.sample(wo, u)
            return (xp.where(s.wi[..., 2:3] > 0, s.weight, xp.zeros_like(s.weight)),)

        return albedo_term
    raise ValueError(f"method must be eval, pdf, sample or albedo; got {method!r}")


class CompiledBRDF:
    """A BRDF whose ``eval``/``pdf``/``sample`` run as compiled kernels (see :func:`compile`).

    The methods take and return NumPy arrays with the protocol's shapes; inputs are converted
    to the compiled ``dtype``. Each method's kernel is built on its first call (its build time
    is in :attr:`compile_seconds`) and kept for the model's *structure*
    (``brdfkit.compiled.structure``: its spec tree with the parameter values left out), which reads
    the values from :attr:`parameters` at each call: a model of the same structure with other
    values reuses it without tracing or compiling. Where a model's constructor cannot take
    abstract values (it reads a parameter's value in Python), its kernels bake the values in,
    one build per parameter set.
    """

    def __init__(self, model: BRDF, dtype: Any = np.float32) -> None:
        if not isinstance(model, BRDF):
            raise ValueError(f"model must be a brdfkit BRDF; got {type(model).__name__}")
        self.model = model
        self.dtype = np.dtype(dtype)
        if self.dtype not in (np.float32, np.float64):
            raise ValueError(f"dtype must be float32 or float64; got {self.dtype}")
        self._kernels: dict[tuple[str, int], Kernel] = {}
        try:
            structure, values = _structure.split(model)
        except TypeError:
            structure, values = None, []
        self._structure = structure
        # what a kernel with the values baked in depends on: the structure and exact values
        self._baked = repr((structure, [(v.dtype.str, v.shape, v.tobytes()) for v in values]))
        self._shapes = [v.shape for v in values]
        self.parameters = np.concatenate(
            [np.asarray(v, dtype=self.dtype).reshape(-1) for v in values] or [np.zeros(0)]
        ).astype(self.dtype)
        """The model's parameter values, flat, in ``brdfkit.compiled.structure.split``'s order."""

    @property
    def channels(self) -> int:
        """The channel count C of the wrapped model."""
        return self.model.channels

    @property
    def compile_seconds(self) -> float:
        """Total time spent tracing and compiling this model's kernels so far (0 for kernels
        another model of the same structure built)."""
        return sum(k.compile_seconds for k in self._kernels.values())

    def built(self, method: str, u_width: int = 0) -> bool:
        """Whether the kernel of ``method`` exists for this model, building nothing."""
        if (method, u_width) in self._kernels:
            return True
        with _STRUCTURAL_LOCK:
            return isinstance(_STRUCTURAL.get(self._structural_key(method, u_width)), Kernel)

    def cached(self, method: str, u_width: int = 0) -> bool:
        """Whether the kernel of ``method`` is built, or can be loaded from the disk cache
        (:mod:`brdfkit.compiled.cache`: its source and machine code), tracing and compiling
        nothing."""
        if self.built(method, u_width):
            return True
        key = self._structural_key(method, u_width)
        stored = None if key is None else kernel_cache.load_record(RECORDS, _record_key(key))
        if stored is not None and stored.get("baked"):
            stored = kernel_cache.load_record(RECORDS, self._baked_key(key))
        if stored is None:
            return False
        return machine_code_cached(stored)

    def shares(self, method: str, u_width: int = 0) -> bool:
        """Whether the kernel of ``method`` serves every model of this structure (the values
        read at each call), not one with this model's values baked in (a build per parameter
        set). Builds the kernel unless this process or the disk cache already knows (a
        structure found to bake its values is recorded on disk, so that is paid once per
        machine); a dictionary look-up after that.

        Raises
        ------
        ValueError
            When it builds a kernel that cannot be built (a primitive the kernels do not take);
            the structure is then known to bake, and the next call answers ``False``.
        """
        key = self._structural_key(method, u_width)
        if key is None:
            return False
        with _STRUCTURAL_LOCK:
            shared = _STRUCTURAL.get(key)
        if shared is None and _known_baked(key):
            with _STRUCTURAL_LOCK:
                shared = _STRUCTURAL.setdefault(key, _BAKED)
        if shared is None:
            self.kernel(method, u_width)
            with _STRUCTURAL_LOCK:
                shared = _STRUCTURAL.get(key)
        return isinstance(shared, Kernel)

    def _structural_key(self, method: str, u_width: int) -> tuple[Any, ...] | None:
        if self._structure is None:
            return None
        return (self._structure, self.dtype.str, method, u_width, vector_bits())

    def kernel(self, method: str, u_width: int = 0) -> Kernel:
        """The kernel of ``method`` (``"eval"``, ``"pdf"``, ``"sample"`` with ``u_width``
        uniforms, ``"albedo"``), built on first use: its ``function`` is the numba function
        other kernels call (:class:`~brdfkit.compiled.kernel.Kernel`)."""
        key = (method, u_width)
        if key not in self._kernels:
            self._kernels[key] = self._build(method, u_width)
        return self._kernels[key]

    def _build(self, method: str, u_width: int) -> Kernel:
        """The kernel of ``method``: the structure's (built once, bound to this model's
        values), else one with this model's values baked in."""
        widths = (3, u_width) if method in ("sample", "albedo") else (3, 3)
        key = self._structural_key(method, u_width)
        if key is not None:
            with _STRUCTURAL_LOCK:
                shared = _STRUCTURAL.get(key)
            if shared is None and _known_baked(key):
                shared = _BAKED
            if shared is None:
                model, count = self.model, len(self._shapes)

                def traced(*args: Any) -> Any:
                    rebuilt = _structure.rebuild(model, iter(args[:count]))
                    return _method(rebuilt, method)(*args[count:])

                try:
                    built = compile_traced(
                        traced, widths, self.dtype, self._shapes, _record_key(key)
                    )
                except (ValueError, TypeError):
                    shared = _BAKED  # the constructor needs concrete values
                    kernel_cache.store_record(RECORDS, _record_key(key), {"baked": True})
                else:
                    with _STRUCTURAL_LOCK:
                        shared = _STRUCTURAL.setdefault(key, built)
                    if shared is built:
                        bound = built.bind(self.parameters)
                        bound.compile_seconds = built.compile_seconds
                        return bound
            with _STRUCTURAL_LOCK:
                _STRUCTURAL.setdefault(key, shared)
            if isinstance(shared, Kernel):
                return shared.bind(self.parameters)
        return compile_traced(
            _method(self.model, method), widths, self.dtype, (), self._baked_key(key)
        )

    def _baked_key(self, key: tuple[Any, ...] | None) -> str | None:
        """The record key of this model's kernel with its values baked in."""
        return None if key is None else kernel_cache.key("baked", self._baked, key[1:])

    def eval(self, wi: Any, wo: Any, *, out: np.ndarray | None = None) -> np.ndarray:
        """f_r(wi, wo), ``(..., C)``, as the model's :meth:`~brdfkit.brdf.BRDF.eval`;
        ``out`` receives the result. Directions laid out component by component
        (``np.asfortranarray``) are read in place and give a result laid out so too, faster
        (see :meth:`Kernel.__call__`)."""
        kernel = self.kernel("eval")
        return kernel(
            directions("wi", wi), directions("wo", wo), out=None if out is None else [out]
        )[0]

    def pdf(self, wi: Any, wo: Any) -> np.ndarray:
        """Solid-angle pdf, ``(...,)``, as the model's :meth:`~brdfkit.brdf.BRDF.pdf`."""
        return self.kernel("pdf")(directions("wi", wi), directions("wo", wo))[0]

    def sample(self, wo: Any, u: Any) -> Sample:
        """Importance sample, as the model's :meth:`~brdfkit.brdf.BRDF.sample`."""
        u = np.asarray(u)
        if u.ndim == 0 or u.shape[-1] not in (2, 3):
            raise ValueError(f"u must have a last axis of length 2 or 3; got shape {u.shape}")
        wi, weight, pdf, delta = self.kernel("sample", u.shape[-1])(directions("wo", wo), u)
        return Sample(wi, weight, pdf, delta)

    def albedo(
        self, wo: Any, samples: int = 4096, seed: int = 0, chunk: int = DEFAULT_CHUNK * 16
    ) -> np.ndarray:
        """Monte Carlo directional albedo with the scrambled-Sobol estimator of
        :meth:`brdfkit.brdf.BRDF.albedo_estimate` (same points, same value), evaluated in
        chunks of ``chunk`` samples so memory stays bounded; ``(..., C)``."""
        from scipy.stats import qmc

        if samples < 1:
            raise ValueError(f"samples must be >= 1; got {samples}")
        wo = directions("wo", wo)
        u = qmc.Sobol(d=3, scramble=True, seed=seed).random(samples).astype(self.dtype)
        batch = wo.shape[:-1]
        flat_wo = wo.reshape(-1, 3)
        total = np.zeros((flat_wo.shape[0], self.channels), dtype=np.float64)
        step = max(1, chunk // max(flat_wo.shape[0], 1))
        kernel = self.kernel("albedo", 3)
        for start in range(0, samples, step):
            (terms,) = kernel(flat_wo[:, None, :], u[None, start : start + step, :])
            total += terms.sum(axis=1, dtype=np.float64)
        return (total / samples).astype(self.dtype).reshape(*batch, self.channels)


def compile(model: BRDF, dtype: Any = np.float32) -> CompiledBRDF:
    """The model with compiled ``eval``/``pdf``/``sample``/``albedo``, same values and API.

    ``brdfkit.compiled.compile(GGX(...)).eval(wi, wo)`` equals ``GGX(...).eval(wi, wo)`` to
    ``dtype`` rounding, at compiled speed on all cores. Nothing of the model is rewritten: its
    own array-API methods are traced and compiled (:mod:`brdfkit.compiled.codegen`). Results
    are ordinary arrays; their memory returns to a pool of at most 512 MiB when nothing
    refers to them any more, and is handed out again (``out=`` still skips even that).

    Raises
    ------
    ValueError
        If ``model`` is not a BRDF or ``dtype`` is not float32/float64; on first use, if a
        parameter varies over the batch.

    Examples
    --------
    >>> import numpy as np
    >>> from brdfkit import compiled
    >>> from brdfkit.brdf import Lambertian
    >>> fast = compiled.compile(Lambertian(0.5))
    >>> fast.eval(np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.6, 0.8]))
    array([0.15915494], dtype=float32)
    """
    return CompiledBRDF(model, dtype)


__all__ = ["CompiledBRDF", "compile"]
