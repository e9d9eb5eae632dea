"""Every hook into numba's and llvmlite's internals (brdfkit.compiled._numba) works on the
installed numba, and a hook that cannot be installed says so.

These tests are the alarm for a numba upgrade: each hook's failure would otherwise be a silent
loss of speed (no disk cache, narrower vectors, no interleave, reference counting)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("numba")

import numba

from brdfkit.compiled import _numba, kernel_tools
from brdfkit.compiled import cache as kernel_cache


@pytest.fixture(autouse=True)
def _no_warnings_yet(monkeypatch):
    """Each test starts with no hook warned about (the warnings are once per process)."""
    monkeypatch.setattr(_numba, "_WARNED", set())


def _quiet(function, *args):
    """``function(*args)``, failing on any RuntimeWarning (a hook that fell back)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        return function(*args)


_PROCESS = textwrap.dedent(
    """
    import json, sys, warnings
    import numpy as np
    warnings.simplefilter("error", RuntimeWarning)
    from brdfkit.compiled import cache as kernel_cache
    namespace = {"__name__": "brdfkit.compiled.cache"}
    exec("def kernel(x):\\n    return x[0] * 3.0 - 1.0\\n", namespace)
    kernel = kernel_cache.njit(namespace["kernel"], sys.argv[1], nogil=True)
    value = kernel(np.array([2.5]))
    print(json.dumps({"value": value, "key": kernel_cache.key_of(kernel),
                      "stats": dict(kernel_cache.STATS),
                      "compiler_context": "numba.np.linalg" in sys.modules}))
    """
)


def _process(cache: Path, key: str) -> dict:
    env = {**os.environ, kernel_cache.ENV: str(cache)}
    src = str(Path(kernel_cache.__file__).parents[2])
    env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    done = subprocess.run(
        [sys.executable, "-c", _PROCESS, key], env=env, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_the_keyed_disk_cache_writes_machine_code_and_a_fresh_process_loads_it(tmp_path):
    key = kernel_cache.key("internals", time.time_ns())
    cold = _process(tmp_path / "cache", key)
    assert cold["key"] == key and cold["value"] == 6.5
    assert cold["stats"].get("misses") == 1 and not cold["stats"].get("hits")
    assert list((tmp_path / "cache").rglob(f"{key}/*.nbc"))  # machine code on disk
    warm = _process(tmp_path / "cache", key)
    assert warm["stats"].get("hits") == 1 and not warm["stats"].get("misses")
    assert not warm["stats"].get("errors") and warm["value"] == cold["value"]
    # compiling loaded numba's whole compiler context (its linalg among it); loading machine
    # code (an array argument: numba's runtime) did not
    assert cold["compiler_context"] and not warm["compiler_context"]


def test_a_cache_that_cannot_be_installed_warns_once_and_compiles_in_memory(tmp_path, monkeypatch):
    def changed():
        raise AttributeError("FunctionCache has no attribute '_impl'")

    monkeypatch.setattr(_numba, "_keyed_cache_class", changed)
    monkeypatch.setenv(kernel_cache.ENV, str(tmp_path / "cache"))
    namespace: dict = {"__name__": "brdfkit.compiled.cache"}
    exec("def kernel(x):\n    return x + 1.0\n", namespace)
    with pytest.warns(RuntimeWarning, match=r"the kernels' disk cache .* numba 0\.\d+"):
        kernel = kernel_cache.njit(namespace["kernel"], "k1", nogil=True)
    assert kernel_cache.key_of(kernel) is None and kernel(1.0) == 2.0
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # once per process
        kernel_cache.njit(namespace["kernel"], "k2", nogil=True)


@pytest.mark.parametrize("bits", ["256", "512"])
def test_the_vector_width_attribute_reaches_the_llvm_ir(bits, monkeypatch):
    monkeypatch.setenv("BRDFKIT_VECTOR_BITS", bits)
    prefer_vector_width = kernel_tools.vector_width_hint()

    @kernel_tools.vector_jit()
    def scale(x, out):
        prefer_vector_width()
        for i in range(x.size):
            out[i] = x[i] * np.float32(2)

    x = np.arange(64, dtype=np.float32)
    out = np.empty_like(x)
    _quiet(scale, x, out)
    np.testing.assert_array_equal(out, 2 * x)
    assert f'"prefer-vector-width"="{bits}"' in scale.inspect_llvm(scale.signatures[0])


_LOOP = "def loop(x, out):\n    for i in range(x.size):\n        out[i] = x[i] * x[i] + 1.0\n"


def _loop(interleave: int | None):
    """A fresh dispatcher of a vectorisable loop, compiled with ``interleave`` (or LLVM's own
    choice); the number of vector multiplications in its optimised IR."""
    namespace: dict = {}
    exec(_LOOP, namespace)
    loop = numba.njit(nogil=True, fastmath=True)(namespace["loop"])
    if interleave is not None:
        _quiet(_numba.compile_interleaved, loop, interleave)
    x = np.arange(100, dtype=np.float32)
    out = np.empty_like(x)
    loop(x, out)
    np.testing.assert_array_equal(out, x * x + 1)
    return loop.inspect_llvm(loop.signatures[0]).count("fmul fast <")


def test_the_interleave_option_reaches_llvm_for_that_dispatcher_alone():
    default = _loop(None)
    assert _loop(4) > _loop(1) >= 1  # four vectors in flight per iteration against one
    assert _loop(None) == default  # reset afterwards: other numba code keeps LLVM's choice


def test_an_interleave_that_cannot_be_set_warns(monkeypatch):
    import llvmlite.binding

    monkeypatch.delattr(llvmlite.binding, "set_option")
    namespace: dict = {}
    exec(_LOOP, namespace)
    loop = numba.njit(namespace["loop"])
    with pytest.warns(RuntimeWarning, match="the vector-interleave option"):
        _numba.compile_interleaved(loop, 2)
    x = np.ones(8)
    out = np.empty_like(x)
    loop(x, out)  # compiles with LLVM's own interleave
    np.testing.assert_array_equal(out, 2 * x)


def test_the_intrinsics_compile_to_their_instructions():
    ops = _quiet(_numba.intrinsics)
    select, maximum, minimum = ops["_select"], ops["_max"], ops["_min"]
    both, either, differ, negate = ops["_and"], ops["_or"], ops["_xor"], ops["_not"]
    rsqrt32 = ops["_rsqrt32"]

    @numba.njit
    def apply(a, b, choose, low, high, logic, root):
        for i in range(a.size):
            choose[i] = select(a[i] > b[i], a[i], b[i])
            low[i], high[i] = minimum(a[i], b[i]), maximum(a[i], b[i])
            p, q = a[i] > 0, b[i] > 0
            logic[i, 0], logic[i, 1] = both(p, q), either(p, q)
            logic[i, 2], logic[i, 3] = differ(p, q), negate(p)
            root[i] = rsqrt32(np.float32(abs(a[i]) + 1))

    rng = np.random.default_rng(1)
    a, b = rng.standard_normal(200), rng.standard_normal(200)
    a[0], b[1] = np.nan, np.nan
    choose, low, high = np.empty(200), np.empty(200), np.empty(200)
    logic, root = np.empty((200, 4), bool), np.empty(200, np.float32)
    apply(a, b, choose, low, high, logic, root)
    np.testing.assert_array_equal(choose[2:], np.where(a > b, a, b)[2:])
    np.testing.assert_array_equal(low, np.minimum(a, b))  # NaN-propagating, as NumPy's
    np.testing.assert_array_equal(high, np.maximum(a, b))
    p, q = a > 0, b > 0
    np.testing.assert_array_equal(logic, np.stack([p & q, p | q, p ^ q, ~p], axis=1))
    exact = 1 / np.sqrt(np.abs(a).astype(np.float32).astype(np.float64) + 1)
    ulp = np.spacing(exact.astype(np.float32)).astype(np.float64)
    assert np.max(np.abs(root - exact)[1:] / ulp[1:]) <= 2
    ir = apply.inspect_llvm(apply.signatures[0])
    assert "llvm.maximum.f64" in ir and "llvm.minimum.f64" in ir and "llvm.sqrt.f32" in ir


def test_the_prefetch_intrinsic_compiles_to_llvm_prefetch():
    prefetch = _quiet(kernel_tools.prefetch)

    @numba.njit
    def total(values):
        s = 0.0
        for j in range(values.size):
            prefetch(values, min(j + 4, values.size - 1))
            s += values[j]
        return s

    values = np.arange(50, dtype=np.float64)
    assert total(values) == values.sum()
    assert "llvm.prefetch" in total.inspect_llvm(total.signatures[0])


def test_kernels_compile_without_numbas_runtime():
    options = _quiet(kernel_tools.without_runtime)
    assert options  # the installed numba has the option: no fallback

    @numba.njit(**options)
    def norm(v):
        return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])

    @numba.njit(**options)
    def allocate(n):
        return np.empty(n)

    assert norm(np.array([3.0, 4.0, 12.0])) == 13.0
    with pytest.raises(numba.core.errors.NumbaError):  # no runtime: no array to allocate
        allocate(3)


def test_without_the_runtime_option_kernels_compile_with_it_and_warn(monkeypatch):
    import numba.core.cpu

    monkeypatch.setattr(numba.core.cpu, "CPUTargetOptions", type("Options", (), {}))
    with pytest.warns(RuntimeWarning, match="compiling without numba's runtime"):
        assert kernel_tools.without_runtime() == {}


def test_toolchain_names_the_installed_versions():
    import llvmlite

    assert _numba.toolchain() == f"numba {numba.__version__}, llvmlite {llvmlite.__version__}"


@pytest.mark.parametrize("package", ["numba", "llvmlite", "numpy", "brdfkit"])
def test_an_installed_version_is_the_one_in_the_packages_metadata(package):
    """Read from the ``.dist-info`` folder's name where there is one beside the package, from
    ``importlib.metadata`` elsewhere (this checkout's brdfkit: an editable install)."""
    from importlib import metadata

    assert _numba.installed_version(package) == metadata.version(package)


def test_a_first_class_function_argument_compiles_its_caller_once():
    """Two compiled functions of one signature passed to a kernel: one specialisation of the
    kernel, each function's own code called through its address."""
    array = kernel_tools.array_type(np.float64, 1)
    arguments = (array, kernel_tools.scalar_type(np.int64))

    @numba.njit
    def double(a, n):
        for i in range(n):
            a[i] *= 2.0

    @numba.njit
    def negate(a, n):
        for i in range(n):
            a[i] = -a[i]

    @numba.njit
    def apply(function, a):
        function(a, a.shape[0])

    a = np.arange(3.0)
    for function in (double, negate):
        apply(kernel_tools.first_class_function(function, arguments), a)
    np.testing.assert_array_equal(a, [-0.0, -2.0, -4.0])
    assert [tuple(s) for s in apply.signatures] == [(_numba.function_type(arguments), array)]


def test_a_first_class_function_is_typed_once_as_numba_types_it():
    from numba.core.types import FunctionType
    from numba.core.types.function_type import CompileResultWAP
    from numba.core.typing.typeof import typeof

    arguments = (kernel_tools.array_type(np.float64, 1),)

    @numba.njit
    def clear(a):
        a[:] = 0.0

    value = kernel_tools.first_class_function(clear, arguments)
    assert isinstance(value, CompileResultWAP)
    assert typeof(value) is value.numba_type
    assert typeof(value) == FunctionType(value.signature()) == _numba.function_type(arguments)


def _imported_after_numba(folder: Path) -> dict:
    """In a new process in ``folder``: numba imported by ``numba_module``; which of SciPy and
    PyYAML that imported, numba's BOUNDSCHECK setting, and whether SciPy imports after."""
    code = textwrap.dedent(
        """
        import json, sys
        from brdfkit.compiled._numba import numba_module
        numba = numba_module()
        seen = {name: name in sys.modules for name in ("scipy", "yaml")}
        import scipy
        seen["boundscheck"] = numba.core.config.BOUNDSCHECK
        seen["scipy_after"] = scipy.__name__
        print(json.dumps(seen))
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=folder, capture_output=True, text=True, check=True
    )
    return json.loads(done.stdout)


def test_numba_module_imports_numba_without_scipy_or_yaml(tmp_path):
    seen = _imported_after_numba(tmp_path)
    assert seen == {"scipy": False, "yaml": False, "boundscheck": None, "scipy_after": "scipy"}


def test_numba_module_keeps_a_numba_config_file(tmp_path):
    pytest.importorskip("yaml")
    (tmp_path / _numba.NUMBA_CONFIG_FILE).write_text("boundscheck: 1\n")
    seen = _imported_after_numba(tmp_path)
    assert seen["yaml"] and seen["boundscheck"] == 1


def test_the_skipping_finder_answers_its_own_thread_only():
    import threading

    finder = _numba._SkipForThisThread(frozenset({"scipy"}), threading.get_ident())
    with pytest.raises(ModuleNotFoundError, match="scipy"):
        finder.find_spec("scipy")
    assert finder.find_spec("numpy") is None
    answers = []
    other = threading.Thread(target=lambda: answers.append(finder.find_spec("scipy")))
    other.start()
    other.join()
    assert answers == [None]


def _first_compile(before: str = "") -> dict:
    """In a new process: ``before``, then numba from ``numba_module`` compiles a function;
    whether SciPy's linear algebra was imported then, and after ``np.correlate`` (which reads
    numba's BLAS flag) and ``np.dot`` (which needs BLAS) compiled and ran."""
    code = textwrap.dedent(
        f"""
        import json, sys
        import numpy as np
        {before}
        from brdfkit.compiled._numba import numba_module
        numba = numba_module()
        seen = {{"linalg": "scipy.linalg" in sys.modules}}
        seen["one"] = numba.njit(lambda x: x + 1)(1.0)
        seen["after_first"] = "scipy.linalg" in sys.modules
        from numba.np import arraymath
        seen["flag"] = type(arraymath._HAVE_BLAS).__name__
        a, b = np.arange(6.0), np.array([1.0, -2.0, 0.5])
        seen["correlate"] = bool(np.array_equal(
            numba.njit(lambda a, b: np.correlate(a, b))(a, b), np.correlate(a, b)))
        seen["after_correlate"] = "scipy.linalg" in sys.modules
        seen["dot"] = float(numba.njit(lambda a: np.dot(a, a))(a))
        print(json.dumps(seen))
        """
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return json.loads(done.stdout)


def test_the_first_compile_leaves_scipy_linalg_until_a_function_needs_it():
    seen = _first_compile()
    assert seen == {
        "linalg": False, "one": 2.0, "after_first": False, "flag": "_BlasCheck",
        "correlate": True, "after_correlate": True, "dot": 55.0,
    }  # fmt: skip


def test_the_first_compile_keeps_numbas_blas_flag_where_scipy_linalg_is_imported():
    seen = _first_compile("import scipy.linalg")
    assert seen["linalg"] and seen["flag"] == "bool" and seen["correlate"]
    assert seen["dot"] == 55.0


_ARRAYS = {
    "float32 C": np.zeros((3, 4), np.float32),
    "float64 F": np.asfortranarray(np.zeros((3, 4))),
    "strided": np.arange(20.0)[::2],
    "one element": np.zeros((1, 1), np.int64),
    "zero-d": np.array(1.5),
    "empty": np.zeros((0, 3), np.uint8),
    "read-only": np.frombuffer(b"\x00" * 16, np.float32),
    "bool": np.zeros(5, np.bool_),
    "complex": np.zeros(2, np.complex64),
    "datetime": np.zeros(2, "datetime64[ns]"),
    "record": np.zeros(2, [("a", np.float32), ("b", np.int16)]),
    "big-endian": np.zeros(3, ">f8"),
}


@pytest.mark.parametrize("name", sorted(_ARRAYS))
def test_arrays_are_typed_as_numbas_own_function_types_them(name):
    """The ``np.ndarray`` typing registered by ``numba_module`` (no ``numpy.ma`` import)
    against numba's own function: the same type, or the same error, for every kind of array."""
    from numba.core.typing import typeof as numba_typeof

    _numba.numba_module()
    value = _ARRAYS[name]
    registered = numba_typeof.typeof_impl.dispatch(np.ndarray)
    assert registered is not numba_typeof._typeof_ndarray  # the hook is installed
    try:
        expected = numba_typeof._typeof_ndarray(value, None)
    except Exception as error:
        with pytest.raises(type(error), match="Unsupported array dtype"):
            registered(value, None)
    else:
        assert registered(value, None) == expected
        assert numba.typeof(value) == expected


def test_a_masked_array_is_still_refused():
    _numba.numba_module()
    with pytest.raises(numba.core.errors.NumbaTypeError, match="MaskedArray"):
        numba.typeof(np.ma.masked_array([1.0, 2.0], mask=[False, True]))


def test_calling_a_compiled_function_on_arrays_leaves_numpy_ma_unimported():
    code = (
        "import sys, numpy as np\n"
        "from brdfkit.compiled._numba import numba_module\n"
        "numba = numba_module()\n"
        "total = numba.njit(lambda a, b: a.sum() + b[0, 0])(np.arange(4.0), np.ones((2, 2)))\n"
        "print(total, 'numpy.ma' in sys.modules)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["7.0", "False"]


def test_a_hook_called_first_imports_numba_through_numba_module():
    # a hook importing numba's submodules itself would import numba beside numba_module
    # (another thread's import could then be handed a partly initialised module); numba's
    # own import, not numba_module's, would also import SciPy
    code = (
        "import sys; from brdfkit.compiled import _numba; _numba.intrinsics(); "
        "print('numba' in sys.modules, 'scipy' in sys.modules)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["True", "False"]
