"""Every use of numba's and llvmlite's internals in brdfkit, each behind a small function.

The compiled back end needs a few things numba offers no public API for:

- LLVM instructions as numba intrinsics (:func:`intrinsics`, :func:`prefetch`): a branch-free
  ``select``, the boolean operators, NaN-propagating ``maximum``/``minimum``, an approximate
  float32 reciprocal square root and a cache prefetch;
- a function attribute that llvmlite's list of known names refuses (:func:`vector_width_hint`:
  ``"prefer-vector-width"``, what clang's ``-mprefer-vector-width`` sets);
- an LLVM option set for one dispatcher's compilations only (:func:`compile_interleaved`:
  ``-force-vector-interleave``);
- numba's per-function disk cache keyed by a string instead of a source file
  (:func:`install_keyed_cache`: numba's cache classes subclassed, the dispatcher's cache
  replaced; a load from it initialises numba's runtime only, not numba's whole compiler
  context), and numba's runtime initialised with its LLVM functions' machine code kept in
  that cache (:func:`initialize_runtime`: numba compiles them in every process);
- compiling without numba's reference-counting runtime (:func:`no_runtime_options`);
- a compiled function as a first-class function value (:func:`first_class`: numba's
  wrapper-address protocol over the compile result), which a kernel calls through a pointer,
  so that the kernel is compiled once for every function of that signature.

Each hook says what happens where numba's internals have changed under it: the intrinsics
and the first-class functions are required (a kernel cannot be built without them) and
raise; the speed hooks (vector width, interleave, disk cache, no runtime) fall back to
numba's defaults, which give the same values (the interleave: to rounding in a batch's last
few elements) at lower speed, and warn once
with a :class:`RuntimeWarning` that names the hook and the installed versions, so that an
upgrade is never a silent performance cliff. ``tests/compiled/test_numba_internals.py``
fails when any hook stops working.

Tested with numba 0.68.1 and llvmlite 0.50.0; ``pyproject.toml`` allows numba from 0.60 (the
project's oldest supported release) to below 0.69 (the first minor release not yet tested).
numba is imported only when a hook is used, so that reading :func:`toolchain` (the kernel
cache's version) costs no import, and the first time from :func:`numba_module`, which spares
its import two optional packages brdfkit does not need it to read (SciPy, PyYAML), and the
process's first compile SciPy's linear algebra (:func:`_defer_blas_check`: numba's flag that
says whether BLAS is there, checked when a compile first reads it).

References
----------
.. [1] S. K. Lam, A. Pitrou, S. Seibert, "Numba: a LLVM-based Python JIT compiler", LLVM-HPC
       2015.
.. [2] Numba documentation, "Notes on Caching" and "High-level extension API: intrinsic".
.. [3] LLVM Language Reference Manual: ``select``, ``llvm.maximum``, ``llvm.prefetch``,
       function attributes.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.util
import pickle
import sys
import threading
import warnings
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

TESTED = "numba 0.68.1, llvmlite 0.50.0"
"""The versions the hooks of this module are tested with."""

_WARNED: set[str] = set()
_WARNED_LOCK = threading.Lock()


def toolchain() -> str:
    """The installed numba and llvmlite versions, read from their packages' metadata (no
    import: the kernel cache's version needs them in processes that never compile)."""
    return f"numba {installed_version('numba')}, llvmlite {installed_version('llvmlite')}"


def installed_version(package: str) -> str:
    """The version of the installed ``package``, from the name of the one ``.dist-info``
    folder of that name beside it (``numba-0.68.1.dist-info``: what ``importlib.metadata``
    reads first, without importing it and the e-mail parser it loads, ~15 ms of a render's
    start-up); from ``importlib.metadata`` where the folder is not there or not alone (an
    egg, a source checkout, two installs)."""
    spec = importlib.util.find_spec(package)
    if spec is not None and spec.submodule_search_locations:
        folder = Path(next(iter(spec.submodule_search_locations))).parent
        found = list(folder.glob(f"{package}-*.dist-info"))
        if len(found) == 1:
            return found[0].name[len(package) + 1 : -len(".dist-info")]
    from importlib import metadata

    return metadata.version(package)


# --------------------------------------------------------------------------- the import
NUMBA_CONFIG_FILE = ".numba_config.yaml"
"""The file in the working folder that numba's import reads its settings from (with PyYAML)."""

_UNUSED_BY_IMPORT = frozenset({"scipy", "yaml"})
_IMPORT_LOCK = threading.Lock()


class _SkipForThisThread:
    """A finder of modules that says the packages ``names`` are not installed, to the thread
    ``thread`` only (every other thread imports them as usual)."""

    def __init__(self, names: frozenset[str], thread: int) -> None:
        self.names, self.thread = names, thread

    def find_spec(self, name: str, path: object = None, target: object = None) -> None:
        if name in self.names and threading.get_ident() == self.thread:
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)


def numba_module() -> ModuleType:
    """numba, imported the first time without two packages its own import reads and brdfkit
    never needs it to: SciPy (whose version numba checks, ~20 ms) and PyYAML (which reads a
    :data:`NUMBA_CONFIG_FILE`; left alone where the working folder has one). Neither is
    imported by numba's import then, for that thread alone; numba imports SciPy itself when
    it compiles a function that needs it, and any later ``import scipy`` imports it as usual.

    The first compile of the process is made not to import SciPy's BLAS either
    (:func:`_defer_blas_check`), nor the first typing of an array NumPy's masked arrays
    (:func:`_type_arrays_without_masked_arrays`).

    Every module of brdfkit that uses numba has it from here, so that the first use, from
    whichever module, imports it so.
    """
    with _IMPORT_LOCK:  # one first import; a later call finds numba imported
        skipped = _UNUSED_BY_IMPORT - sys.modules.keys()
        if Path(NUMBA_CONFIG_FILE).is_file():
            skipped -= {"yaml"}
        finder = _SkipForThisThread(skipped, threading.get_ident())
        sys.meta_path.insert(0, finder)
        try:
            import numba
        finally:
            sys.meta_path.remove(finder)
        _defer_blas_check()
        _type_arrays_without_masked_arrays()
    return numba


def _numba_first(function: Callable[..., Any]) -> Callable[..., Any]:
    """``function``, run after :func:`numba_module` has imported numba: the hooks import
    numba's submodules directly, and a thread doing so while another thread imports numba
    (numba's modules import one another circularly) can be handed a partly initialised
    module."""

    @functools.wraps(function)
    def run(*args: Any, **kwargs: Any) -> Any:
        numba_module()
        return function(*args, **kwargs)

    return run


_BLAS = frozenset({"scipy", "scipy.linalg"})


class _BlasCheck:
    """numba's ``arraymath._HAVE_BLAS`` (whether SciPy's BLAS is there), asked only when a
    compile reads it: ``check()`` once, at the first truth test."""

    def __init__(self, check: Any) -> None:
        self._check, self._value = check, None

    def __bool__(self) -> bool:
        if self._value is None:
            self._value = bool(self._check())
        return self._value


@functools.cache
def _defer_blas_check() -> None:
    """Have the process's first compile import numba's array functions without SciPy's BLAS.

    numba's first compile imports ``numba.np.arraymath``, whose import checks for BLAS by
    importing ``scipy.linalg`` (a third of a second, before the first compile can start),
    for a flag that only ``np.convolve`` and ``np.correlate`` read. A listener of numba's
    ``numba:compile`` event imports that module at the first compile with SciPy's linear
    algebra hidden from that thread, and puts in the flag's place a :class:`_BlasCheck`,
    which checks when the flag is first read; later compiles find the module imported.
    ``np.dot`` and ``np.linalg`` import SciPy themselves when compiled, as before.
    """
    try:
        from numba.core import event
    except ImportError as error:
        warn_once("the deferred BLAS check", "the first compile imports SciPy", error)
        return

    class FirstCompile(event.Listener):
        def on_start(self, _: Any) -> None:
            skipped = _BLAS - sys.modules.keys()
            if "numba.np.arraymath" in sys.modules or not skipped:
                return
            finder = _SkipForThisThread(skipped, threading.get_ident())
            sys.meta_path.insert(0, finder)
            try:
                from numba.np import arraymath
            finally:
                sys.meta_path.remove(finder)
            if arraymath._HAVE_BLAS is False:
                arraymath._HAVE_BLAS = _BlasCheck(arraymath._check_blas)

        def on_end(self, _: Any) -> None:
            return

    event.register("numba:compile", FirstCompile())


@functools.cache
def _type_arrays_without_masked_arrays() -> None:
    """Have ``numba.typeof`` type a plain NumPy array without importing ``numpy.ma``.

    numba's type of an ``np.ndarray`` (what a compiled function's first call with each kind
    of array asks) first refuses masked arrays by ``isinstance(value, np.ma.MaskedArray)``,
    and NumPy imports ``numpy.ma`` (11-17 ms, in every process that loads its kernels) to
    answer. A value whose type is ``np.ndarray`` itself is no masked array: this registers, for
    ``np.ndarray``, numba's own function with that test answered so for such values, and
    numba's function unchanged for subclasses (masked arrays among them). Installed on the
    numba version these hooks are tested with only (:data:`TESTED`); elsewhere numba types
    arrays as it does."""
    try:
        import numpy as np
        from numba.core import errors, types
        from numba.core.typing.typeof import typeof_impl
        from numba.np import numpy_support

        numba_version = sys.modules["numba"].__version__
        original = typeof_impl.dispatch(np.ndarray)
    except (ImportError, AttributeError, KeyError):
        return
    if f"numba {numba_version}," not in TESTED or original.__name__ != "_typeof_ndarray":
        return

    def typeof_ndarray(value: Any, context: Any) -> Any:
        if type(value) is not np.ndarray:
            return original(value, context)
        try:
            dtype = numpy_support.from_dtype(value.dtype)
        except errors.NumbaNotImplementedError:
            raise errors.NumbaValueError(f"Unsupported array dtype: {value.dtype}") from None
        layout = numpy_support.map_layout(value)
        return types.Array(dtype, value.ndim, layout, readonly=not value.flags.writeable)

    typeof_impl.register(np.ndarray, typeof_ndarray)


def warn_once(hook: str, consequence: str, error: BaseException) -> None:
    """One :class:`RuntimeWarning` per hook and process: ``hook`` could not be installed on
    the installed numba, with the ``consequence`` and the ``error`` that said so."""
    with _WARNED_LOCK:
        if hook in _WARNED:
            return
        _WARNED.add(hook)
    warnings.warn(
        f"brdfkit.compiled: {hook} could not be installed on {toolchain()} (tested with "
        f"{TESTED}): {type(error).__name__}: {error}; {consequence}",
        RuntimeWarning,
        stacklevel=3,
    )


# --------------------------------------------------------------------------- intrinsics
@functools.cache
@_numba_first
def intrinsics() -> dict[str, Any]:
    """numba intrinsics of single LLVM instructions, by the names the generated kernels use:
    ``_select(c, a, b)`` (``select``), ``_and``, ``_or``, ``_xor``, ``_not`` (bitwise on
    booleans), ``_max``, ``_min`` (``llvm.maximum``/``llvm.minimum``: NaN-propagating as
    ``np.maximum``), ``_rsqrt32`` (``1/sqrt`` of a positive normal float32 with the
    approximate-function flag: LLVM's reciprocal-square-root estimate and a Newton step).

    Python's conditional expression and ``and``/``or`` compile to branches, which keep LLVM
    from vectorising a loop; these keep a kernel's body straight-line.

    Raises
    ------
    RuntimeError
        Where numba's intrinsic API or llvmlite's IR builder has changed: no kernel can be
        built without them.
    """
    try:
        from llvmlite import ir
        from numba.core import types
        from numba.extending import intrinsic
    except ImportError as error:
        raise RuntimeError(
            f"brdfkit.compiled needs numba's intrinsic API and llvmlite's IR builder; "
            f"{toolchain()} (tested with {TESTED}) lacks them: {error}"
        ) from error

    def binary(build: Callable[..., Any]) -> Any:
        @intrinsic
        def op(typingctx: Any, a: Any, b: Any) -> Any:
            def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
                return build(builder, *args)

            return a(a, b), codegen

        return op

    @intrinsic
    def select(typingctx: Any, condition: Any, a: Any, b: Any) -> Any:
        if a != b:
            return None

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            return builder.select(*args)

        return a(condition, a, b), codegen

    def float_binary(llvm_name: str) -> Any:
        """The LLVM intrinsic ``llvm_name`` of two floats of one type (llvmlite declares only
        some intrinsics itself)."""

        @intrinsic
        def op(typingctx: Any, a: Any, b: Any) -> Any:
            if a != b or not isinstance(a, types.Float):
                return None

            def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
                t = args[0].type
                function = _declare(builder, f"{llvm_name}.{t.intrinsic_name}", t, 2)
                return builder.call(function, args)

            return a(a, b), codegen

        return op

    @intrinsic
    def rsqrt32(typingctx: Any, a: Any) -> Any:
        if a != types.float32:
            return None

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            t = args[0].type
            flags = ("afn", "ninf", "arcp", "contract")
            root = builder.call(_declare(builder, "llvm.sqrt.f32", t, 1), args, fastmath=flags)
            return builder.fdiv(ir.Constant(t, 1.0), root, flags=flags)

        return a(a), codegen

    @intrinsic
    def not_(typingctx: Any, a: Any) -> Any:
        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            return builder.not_(args[0])

        return a(a), codegen

    return {
        "_select": select,
        "_and": binary(lambda b, x, y: b.and_(x, y)),
        "_or": binary(lambda b, x, y: b.or_(x, y)),
        "_xor": binary(lambda b, x, y: b.xor(x, y)),
        "_not": not_,
        "_max": float_binary("llvm.maximum"),
        "_min": float_binary("llvm.minimum"),
        "_rsqrt32": rsqrt32,
    }


def _declare(builder: Any, name: str, t: Any, arity: int) -> Any:
    """The LLVM function ``name`` of ``arity`` arguments of type ``t``, returning ``t``,
    declared once in the builder's module."""
    from llvmlite import ir

    function = builder.module.globals.get(name)
    if function is None:
        function = ir.Function(builder.module, ir.FunctionType(t, [t] * arity), name)
    return function


@functools.cache
@_numba_first
def prefetch() -> Callable[..., None]:
    """The numba intrinsic ``prefetch(array, i)``: LLVM's ``llvm.prefetch`` (read, keep in all
    cache levels) of element ``i`` of a C-contiguous ``array``; a hint, no effect on values.
    A strided array is a typing error (no element pointer to compute).

    Raises
    ------
    RuntimeError
        As :func:`intrinsics`.
    """
    intrinsics()  # the same imports, and their error
    from llvmlite import ir
    from numba.core import cgutils, types
    from numba.extending import intrinsic

    @intrinsic
    def prefetch_element(typingctx: Any, array: Any, index: Any) -> Any:
        if not (isinstance(array, types.Array) and array.layout == "C"):
            return None
        if not isinstance(index, types.Integer):
            return None

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            data = context.make_array(signature.args[0])(context, builder, args[0]).data
            offset = context.cast(builder, args[1], signature.args[1], types.intp)
            # as i8*: one declaration serves arrays of any dtype in a module
            pointer = builder.bitcast(builder.gep(data, [offset]), ir.IntType(8).as_pointer())
            i32 = ir.IntType(32)
            function = cgutils.get_or_insert_function(
                builder.module,
                ir.FunctionType(ir.VoidType(), [pointer.type, i32, i32, i32]),
                "llvm.prefetch.p0",
            )
            builder.call(function, [pointer, i32(0), i32(3), i32(1)])
            return context.get_dummy_value()

        return types.none(array, index), codegen

    return prefetch_element


@functools.cache
@_numba_first
def array_intrinsics() -> dict[str, Any]:
    """numba intrinsics that make arrays inside the calling function:

    - ``empty(shape, dtype)``: ``np.empty(shape, dtype)`` (``shape`` an integer or a tuple of
      integers, ``dtype`` a NumPy scalar type; C order): numba's checks of the shape, its
      size computation with overflow checks, its alignment and its runtime's allocation;
    - ``flat(array)``: the 1-D view of a C-contiguous ``array`` (``array.reshape(-1)``),
      sharing its memory (a borrowed reference, counted as numba counts a view).

    numba compiles ``np.empty``'s allocation and ``reshape``'s shape check as functions of
    their own, whose environments (kept with the caller's machine code on disk) name
    ``numba.np.arrayobj``: a process that only loads the code then imports that module to
    rebuild them (~25 ms of a warm render's start-up). Lowered in place, these have no
    function and no environment; numba's lowering helpers (:func:`_array_helpers`) are
    imported when they are compiled.

    Raises
    ------
    RuntimeError
        Where numba's intrinsic API or its array helpers have changed.
    """
    try:
        from llvmlite import ir
        from numba.core import cgutils, types
        from numba.core.imputils import impl_ret_borrowed
        from numba.extending import intrinsic
    except ImportError as error:
        raise RuntimeError(
            f"brdfkit.compiled needs numba's intrinsic API; {toolchain()} (tested with "
            f"{TESTED}) lacks it: {error}"
        ) from error

    def dimensions(shape: Any) -> int | None:
        if isinstance(shape, types.Integer):
            return 1
        if isinstance(shape, types.BaseTuple) and all(
            isinstance(t, types.Integer) for t in shape.types
        ):
            return len(shape.types)
        return None

    too_big = (
        "array is too big; `arr.size * arr.dtype.itemsize` is larger than the maximum "
        "possible size."
    )

    def checked_product(builder: Any, values: list[Any], overflow: Any) -> tuple[Any, Any]:
        product = values[0]
        for value in values[1:]:
            both = builder.smul_with_overflow(product, value)
            product = builder.extract_value(both, 0)
            overflow = builder.or_(overflow, builder.extract_value(both, 1))
        return product, overflow

    @intrinsic
    def empty(typingctx: Any, shape: Any, dtype: Any) -> Any:
        ndim = dimensions(shape)
        if not ndim or not isinstance(dtype, types.NumberClass):
            return None

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            parse_shape, make_array, populate_array = _array_helpers()
            array_type, shapes = parse_shape(context, builder, signature, args)
            intp, data_type = types.intp, context.get_data_type(array_type.dtype)
            itemsize = context.get_constant(intp, context.get_abi_sizeof(data_type))
            one, no = context.get_constant(intp, 1), ir.Constant(ir.IntType(1), 0)
            length, overflow = checked_product(builder, [one, *shapes], no)
            size, overflow = checked_product(builder, [length, itemsize], overflow)
            with builder.if_then(overflow, likely=False):
                context.call_conv.return_user_exc(builder, ValueError, (too_big,))
            strides = [itemsize]
            for extent in reversed(shapes[1:]):
                strides.append(builder.mul(strides[-1], extent))
            alignment = context.get_preferred_array_alignment(array_type.dtype)
            meminfo = context.nrt.meminfo_alloc_aligned(
                builder, size, context.get_constant(types.uint32, alignment)
            )
            data = context.nrt.meminfo_data(builder, meminfo)
            array, index = make_array(array_type)(context, builder), context.get_value_type(intp)
            populate_array(
                array,
                data=builder.bitcast(data, data_type.as_pointer()),
                shape=cgutils.pack_array(builder, shapes, ty=index),
                strides=cgutils.pack_array(builder, strides[::-1], ty=index),
                itemsize=itemsize,
                meminfo=meminfo,
            )
            return array._getvalue()

        return types.Array(dtype.instance_type, ndim, "C")(shape, dtype), codegen

    @intrinsic
    def flat(typingctx: Any, array: Any) -> Any:
        if not isinstance(array, types.Array) or array.layout != "C":
            return None
        view_type = array.copy(ndim=1)

        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            _, make_array, populate_array = _array_helpers()
            source = make_array(array)(context, builder, args[0])
            view = make_array(view_type)(context, builder)
            intp = context.get_value_type(types.intp)
            populate_array(
                view,
                data=source.data,
                shape=cgutils.pack_array(builder, [source.nitems], ty=intp),
                strides=cgutils.pack_array(builder, [source.itemsize], ty=intp),
                itemsize=source.itemsize,
                meminfo=source.meminfo,
                parent=source.parent,
            )
            return impl_ret_borrowed(context, builder, view_type, view._getvalue())

        return view_type(array), codegen

    return {"empty": empty, "flat": flat}


@functools.cache
def _array_helpers() -> tuple[Callable[..., Any], ...]:
    """numba's lowering helpers of arrays (``numba.np.arrayobj``: its parsing of a shape, its
    array structure and the filling of one), imported when an intrinsic of
    :func:`array_intrinsics` is compiled, not when its machine code is loaded.

    Raises
    ------
    RuntimeError
        Where numba's array helpers have changed.
    """
    try:
        from numba.np import arrayobj

        return arrayobj._parse_empty_args, arrayobj.make_array, arrayobj.populate_array
    except (ImportError, AttributeError) as error:
        raise RuntimeError(
            f"brdfkit.compiled needs numba's array helpers; {toolchain()} (tested with "
            f"{TESTED}) lacks them: {error}"
        ) from error


def function_type(argument_types: tuple[Any, ...]) -> Any:
    """numba's type of a first-class function of ``argument_types`` returning nothing (the
    type :func:`first_class`'s values have)."""
    from numba import types

    return types.FunctionType(types.none(*argument_types))


@_numba_first
def first_class(dispatcher: Any, argument_types: tuple[Any, ...]) -> Any:
    """``dispatcher`` compiled for ``argument_types`` (or loaded: from this process or its
    disk cache) as a first-class function value: numba types it as
    :func:`function_type` ``(argument_types)`` and a kernel taking it as an argument calls it
    through its address (numba's C wrapper of the compiled function; no exceptions), so that
    the kernel is compiled once for all functions of that type, not once per function.

    Raises
    ------
    RuntimeError
        Where numba's wrapper-address protocol has changed (no kernel taking functions can
        be built without it).
    """
    try:
        value_class = _first_class_value()
    except ImportError as error:
        raise RuntimeError(
            f"brdfkit.compiled needs numba's first-class functions; {toolchain()} (tested "
            f"with {TESTED}) lacks them: {error}"
        ) from error
    dispatcher.compile(argument_types)
    return value_class(dispatcher.overloads[tuple(argument_types)])


@functools.cache
def _first_class_value() -> type:
    """numba's first-class function value (``CompileResultWAP``) that keeps its numba type:
    numba's ``typeof`` builds a new ``FunctionType`` of the value at every call of a kernel
    taking it (~20 µs a function argument, with the GIL held); this one is typed once, to
    the same type (``typeof_impl.register``, numba's extension API for typing values)."""
    # numba's typeof and data model of these values, which a process that loads its
    # kernels from the disk cache (no compiler context) has not imported yet
    import numba.experimental.function_type  # noqa: F401
    from numba.core.types import FunctionType
    from numba.core.types.function_type import CompileResultWAP
    from numba.core.typing.typeof import typeof_impl

    class TypedCompileResult(CompileResultWAP):
        def __init__(self, compile_result: Any) -> None:
            super().__init__(compile_result)
            self.numba_type = FunctionType(compile_result.signature)

    typeof_impl.register(TypedCompileResult)(lambda value, context: value.numba_type)
    return TypedCompileResult


# --------------------------------------------------------------------------- speed hooks
@functools.cache
@_numba_first
def vector_width_hint(bits: int) -> Any:
    """A numba intrinsic ``prefer_vector_width()`` that marks the function calling it
    ``"prefer-vector-width"="bits"`` (what clang's ``-mprefer-vector-width`` does): the SIMD
    width for that function alone, not for every numba function of the process as
    ``NUMBA_CPU_FEATURES`` would.

    llvmlite accepts only a fixed list of attribute names, without LLVM's string attributes;
    the set underneath renders any attribute it holds, so the attribute is added to the set
    itself. Where a later llvmlite stores attributes otherwise, the function keeps LLVM's
    default width (same values, fewer lanes where AVX-512 is there) and a warning says so.
    """
    intrinsics()
    from numba.core import types
    from numba.extending import intrinsic

    attribute = f'"prefer-vector-width"="{bits}"'

    @intrinsic
    def prefer_vector_width(typingctx: Any) -> Any:
        def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
            try:
                set.add(builder.function.attributes, attribute)
            except (TypeError, AttributeError) as error:
                warn_once("the vector-width attribute", "kernels use LLVM's default width", error)
            return context.get_dummy_value()

        return types.none(), codegen

    return prefer_vector_width


@_numba_first
def compile_interleaved(dispatcher: Any, interleave: int) -> None:
    """Have numba compile ``dispatcher`` (each signature, also when another function calls
    it) with LLVM's ``-force-vector-interleave=interleave``: set under numba's compiler lock,
    which every compilation of the process holds, and reset to 0 (LLVM's own choice)
    afterwards, so that other numba code keeps LLVM's default.

    Where numba's compiler lock or llvmlite's option setter is gone, ``dispatcher`` compiles
    with LLVM's own interleave (the same values but in a batch's last few elements, which
    may round differently; slower) and a warning says so.
    """
    try:
        import llvmlite.binding as llvm
        from numba.core.compiler_lock import global_compiler_lock

        set_option = llvm.set_option
        compile_signature = dispatcher.compile
    except (ImportError, AttributeError) as error:
        warn_once("the vector-interleave option", "kernels use LLVM's own interleave", error)
        return

    def compile_with_interleave(signature: Any) -> Any:
        with global_compiler_lock:
            set_option("", f"-force-vector-interleave={interleave}")
            try:
                return compile_signature(signature)
            finally:
                set_option("", "-force-vector-interleave=0")

    dispatcher.compile = compile_with_interleave


@_numba_first
def no_runtime_options() -> dict[str, Any]:
    """``numba.njit`` options that compile a function without numba's runtime (no reference
    counting of the arrays it passes on: atomic updates of counts that threads share).

    Where numba no longer has the option, ``{}`` (the function compiles with the runtime:
    the same values, slower) and a warning says so."""
    try:
        from numba.core.cpu import CPUTargetOptions

        if not hasattr(CPUTargetOptions, "_nrt"):
            raise AttributeError("CPUTargetOptions has no _nrt option")
    except (ImportError, AttributeError) as error:
        warn_once("compiling without numba's runtime", "kernels count references", error)
        return {}
    return {"_nrt": False}


# --------------------------------------------------------------------------- disk cache
_UNREADABLE = (OSError, EOFError, pickle.UnpicklingError, ValueError, TypeError, KeyError)
"""What reading a corrupt or truncated cache entry raises (pickle's and numba's rebuild)."""


@_numba_first
def install_keyed_cache(
    dispatcher: Any, cache_key: str, path: Path, count: Callable[[str], None]
) -> bool:
    """Give a numba dispatcher (not yet compiled) numba's disk cache in folder ``path``,
    keyed by ``cache_key`` instead of a source file and its closure's cells (which a
    generated kernel lacks, and whose pickles differ in every process). ``count(event)`` is
    told of each ``"hits"``, ``"misses"`` and ``"errors"`` (an entry that could not be read
    or written: compiled, and written again where possible).

    Returns whether the cache is installed. Where numba's cache classes have changed, the
    dispatcher compiles in memory in every process (seconds per kernel) and a warning says
    so.
    """
    try:
        dispatcher._cache = _keyed_cache_class()(dispatcher.py_func, cache_key, path, count)
    except (ImportError, AttributeError, TypeError) as error:
        warn_once("the kernels' disk cache", "kernels compile in every process", error)
        return False
    return True


@_numba_first
def initialize_runtime(target_context: Any, folder: Path) -> None:
    """Initialise numba's runtime (NRT) as ``rtsys.initialize`` does, with the machine code
    of its LLVM functions (reference counts, memory-info accessors) kept in ``folder``: numba
    compiles them again in every process (25–60 ms, most of a process that only loads its
    kernels), here a process loads them (~2 ms) once one has compiled them on this machine
    (the file names the CPU and its features; the folder, numba's version). Written
    atomically (temporary and rename); an unreadable file is compiled again and replaced.

    Where numba's runtime has changed, ``rtsys.initialize`` itself runs and a warning says
    so."""
    try:
        from numba.core import config
        from numba.core.compiler_lock import global_compiler_lock
        from numba.core.runtime import _nrt_python, nrtdynmod, rtsys

        helpers = _nrt_python.c_helpers
        create_module = nrtdynmod.create_nrt_module
    except (ImportError, AttributeError) as error:
        warn_once("the runtime's cache", "the runtime compiles in every process", error)
        from numba.core.runtime import rtsys

        rtsys.initialize(target_context)
        return
    import llvmlite.binding as llvm

    with global_compiler_lock:
        if rtsys._init:
            return
        if config.NRT_STATS:
            _nrt_python.memsys_enable_stats()
        for name, address in helpers.items():
            llvm.add_symbol(name if name.startswith("_") else f"NRT_{name}", address)
        try:
            library = _runtime_library(target_context, create_module, folder)
        except AttributeError as error:  # numba's libraries have changed
            warn_once("the runtime's cache", "the runtime compiles in every process", error)
            rtsys.initialize(target_context)
            return
        rtsys._library = library
        rtsys._init = True


def _runtime_library(target_context: Any, create_module: Callable[..., Any], folder: Path) -> Any:
    """The library of numba's runtime functions: loaded from ``folder``, or compiled (with
    its machine code kept) and written there."""
    codegen = target_context.codegen()
    machine = hashlib.sha256(repr(codegen.magic_tuple()).encode()).hexdigest()[:16]
    path = folder / f"runtime-{machine}.pickle"
    try:
        return codegen.unserialize_library(pickle.loads(path.read_bytes()))
    except _UNREADABLE:  # not there yet, or unreadable: compiled, then written
        module, library = create_module(target_context)
        library.enable_object_caching()
        library.add_ir_module(module)
        library.finalize()
        from brdfkit.errors import OutputError
        from brdfkit.io import atomic_write_bytes

        with contextlib.suppress(OutputError):  # a folder it cannot write: compiled each time
            atomic_write_bytes(path, pickle.dumps(library.serialize_using_object_code()))
        return library


@functools.cache
def _keyed_cache_class() -> type:
    """numba's per-function cache, keyed by our key and stored in our folder (a subclass of
    its ``FunctionCache`` that needs no source file and does not pickle closures)."""
    from numba.core.caching import (
        CompileResultCacheImpl,
        FunctionCache,
        IndexDataCacheFile,
        _CacheLocator,
    )

    class Locator(_CacheLocator):
        def __init__(self, path: Path) -> None:
            self._path = str(path)
            self._py_file = "<brdfkit kernel>"

        def get_cache_path(self) -> str:
            return self._path

        def get_source_stamp(self) -> str:
            return "brdfkit"  # the key (the folder's name) already says what the code is

        def get_disambiguator(self) -> str:
            return ""

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> None:
            return None

    class Impl(CompileResultCacheImpl):
        def __init__(self, py_func: Any, path: Path) -> None:
            self._lineno = py_func.__code__.co_firstlineno
            self._locator = Locator(path)
            self._filename_base = self.get_filename_base("kernel", getattr(sys, "abiflags", ""))

    class KeyedCache(FunctionCache):
        def __init__(
            self, py_func: Any, cache_key: str, path: Path, count: Callable[[str], None]
        ) -> None:
            self._name = repr(py_func)
            self._py_func = py_func
            self._key = cache_key
            self._count = count
            self._impl = Impl(py_func, path)
            self._cache_path = str(path)
            self._cache_file = IndexDataCacheFile(
                cache_path=str(path),
                filename_base=self._impl.filename_base,
                source_stamp=self._impl.locator.get_source_stamp(),
            )
            self.enable()

        def _index_key(self, sig: Any, codegen: Any) -> tuple[Any, ...]:
            return (sig, codegen.magic_tuple(), self._key)

        def load_overload(self, sig: Any, target_context: Any) -> Any:
            # numba's own first refreshes the target context: it imports and registers every
            # numba extension (linalg, which imports scipy.linalg; random; typed containers;
            # ~0.9 s), which compiling needs and loading machine code does not (a compile
            # after a miss refreshes the context itself). Loaded code calls numba's runtime
            # (the wrapper's array arguments), so that is initialised here.
            try:
                initialize_runtime(target_context, Path(self._cache_path).parent)
                with self._guard_against_spurious_io_errors():
                    data = self._load_overload(sig, target_context)
            except _UNREADABLE:  # a corrupt entry: compile, then overwrite it
                self._count("errors")
                return None
            self._count("hits" if data is not None else "misses")
            return data

        def save_overload(self, sig: Any, data: Any) -> None:
            try:
                super().save_overload(sig, data)
            except _UNREADABLE:
                try:  # an unreadable index: a fresh one, then the entry
                    self._cache_file.flush()
                    super().save_overload(sig, data)
                except OSError:  # unwritable (disk full, permissions): kept in memory
                    self._count("errors")

    return KeyedCache


__all__ = [
    "NUMBA_CONFIG_FILE",
    "TESTED",
    "array_intrinsics",
    "compile_interleaved",
    "first_class",
    "function_type",
    "initialize_runtime",
    "install_keyed_cache",
    "intrinsics",
    "no_runtime_options",
    "numba_module",
    "prefetch",
    "toolchain",
    "vector_width_hint",
    "warn_once",
]
