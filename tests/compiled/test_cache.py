"""The on-disk kernel cache (brdfkit.compiled.cache): hits across processes, clean fallbacks."""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("numba")

from brdfkit.compiled import cache as kernel_cache


def _fresh_kernel(cache_key: str):
    """A new dispatcher of the same function (as a new process would make it) with the disk
    cache of ``cache_key``."""
    namespace: dict = {"__name__": "brdfkit.compiled.cache"}
    exec("def kernel(x):\n    return x * 2.0 + 1.0\n", namespace)
    return kernel_cache.njit(namespace["kernel"], cache_key, nogil=True)


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    monkeypatch.setenv(kernel_cache.ENV, str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_a_new_dispatcher_loads_the_machine_code_from_disk(cache_dir):
    key = kernel_cache.key("test", time.time_ns())
    first = _fresh_kernel(key)
    assert kernel_cache.key_of(first) == key and not kernel_cache.has(key)
    before = kernel_cache.STATS.copy()
    assert first(3.0) == 7.0
    assert kernel_cache.STATS["misses"] == before["misses"] + 1
    assert kernel_cache.has(key)
    assert list((cache_dir / kernel_cache.version() / "numba" / key).glob("*.nbc"))
    second = _fresh_kernel(key)
    assert second(3.0) == 7.0
    assert kernel_cache.STATS["hits"] == before["hits"] + 1
    assert sum(second.stats.cache_hits.values()) == 1  # numba's own counter agrees


def test_a_corrupt_entry_is_compiled_again_and_replaced(cache_dir):
    key = kernel_cache.key("corrupt", time.time_ns())
    _fresh_kernel(key)(1.0)
    entry = cache_dir / kernel_cache.version() / "numba" / key
    for path in entry.iterdir():
        path.write_bytes(b"\x80\x04not a pickle")
    errors = kernel_cache.STATS["errors"]
    assert _fresh_kernel(key)(2.0) == 5.0
    assert kernel_cache.STATS["errors"] == errors + 1
    hits = kernel_cache.STATS["hits"]
    assert _fresh_kernel(key)(2.0) == 5.0  # the entry was written again
    assert kernel_cache.STATS["hits"] == hits + 1


def test_an_unwritable_cache_compiles_in_memory(tmp_path, monkeypatch):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.setenv(kernel_cache.ENV, str(blocker / "cache"))  # cannot be created
    assert kernel_cache.directory() is None
    kernel = _fresh_kernel(kernel_cache.key("unwritable"))
    assert kernel_cache.key_of(kernel) is None
    assert kernel(1.0) == 3.0
    kernel_cache.store_record("accel", "k", {"a": 1})  # no error
    assert kernel_cache.load_record("accel", "k") is None


def test_an_empty_override_turns_the_cache_off(monkeypatch):
    monkeypatch.setenv(kernel_cache.ENV, "")
    assert kernel_cache.root() is None and kernel_cache.directory() is None


def test_records_round_trip_and_a_corrupt_one_is_a_miss(cache_dir):
    kernel_cache.store_record("accel", "abc", {"source": "x", "n": 2})
    assert kernel_cache.load_record("accel", "abc") == {"source": "x", "n": 2}
    path = cache_dir / kernel_cache.version() / "accel" / "abc.json"
    path.write_text("{truncated", encoding="utf-8")
    assert kernel_cache.load_record("accel", "abc") is None
    path.write_text("[1, 2]", encoding="utf-8")
    assert kernel_cache.load_record("accel", "abc") is None


def test_only_stale_folders_of_this_cache_are_pruned(tmp_path, monkeypatch):
    base = tmp_path / "cache"
    stale, recent, foreign = base / "old-version", base / "recent-version", base / "not-ours"
    for folder in (stale, recent, foreign):
        folder.mkdir(parents=True)
    (stale / kernel_cache._MARKER).touch()
    (recent / kernel_cache._MARKER).touch()
    old = time.time() - (kernel_cache.STALE_DAYS + 1) * 86400
    os.utime(stale / kernel_cache._MARKER, (old, old))
    os.utime(foreign, (old, old))
    monkeypatch.setenv(kernel_cache.ENV, str(base))
    assert kernel_cache.directory() == base / kernel_cache.version()
    assert not stale.exists() and recent.exists() and foreign.exists()


_PROCESS = textwrap.dedent(
    """
    import json, sys
    import numpy as np
    from brdfkit.compiled import cache as kernel_cache
    from brdfkit import compiled
    from brdfkit.brdf import MODELS
    wi = np.array([[0.3, 0.2, 0.9]]) / np.linalg.norm([0.3, 0.2, 0.9])
    wo = np.array([[-0.4, 0.1, 0.8]]) / np.linalg.norm([-0.4, 0.1, 0.8])
    f = compiled.compile(MODELS["ggx"](alpha=0.37, material="Au")).eval(wi, wo)
    print(json.dumps({"stats": dict(kernel_cache.STATS), "f": f.tolist()}))
    """
)


def _run(cache: Path, code: str = _PROCESS) -> dict:
    env = {**os.environ, kernel_cache.ENV: str(cache)}
    src = str(Path(kernel_cache.__file__).parents[2])
    env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_a_second_process_neither_traces_nor_compiles(tmp_path):
    cold = _run(tmp_path / "cache")
    assert cold["stats"].get("misses", 0) >= 1 and cold["stats"].get("hits", 0) == 0
    assert cold["stats"].get("record_misses", 0) >= 1
    warm = _run(tmp_path / "cache")
    assert warm["stats"].get("misses", 0) == 0 and warm["stats"].get("hits", 0) >= 1
    assert warm["stats"].get("record_hits", 0) >= 1 and not warm["stats"].get("record_misses")
    assert warm["stats"].get("errors", 0) == 0
    np.testing.assert_array_equal(warm["f"], cold["f"])  # the same machine code


_RENDER = textwrap.dedent(
    """
    import json
    import sys
    import numpy as np
    from brdfkit.compiled import cache as kernel_cache
    from brdfkit.brdf import MODELS
    from brdfkit.light import EnvironmentMap
    from brdfkit.render import render_sphere
    env = EnvironmentMap(np.random.default_rng(0).random((8, 16, 3)) + 0.1)
    ggx = MODELS["ggx"](alpha=0.3, material="Au")
    image = render_sphere(ggx, env, 12, samples=4, compiled=True)
    from numba.core import entrypoints
    from brdfkit.render._reflection_kernels import tile_kernel
    print(json.dumps({
        "stats": dict(kernel_cache.STATS), "f": image.tolist(),
        "extensions_scanned": entrypoints._already_initialized,
        "tile_signatures": len(tile_kernel(np.float32, 3, 3).signatures),
        "array_module": "numba.np.arrayobj" in sys.modules,
    }))
    """
)


@pytest.mark.slow
def test_a_second_process_loads_the_tile_kernel_and_renders_the_same_image(tmp_path):
    cold = _run(tmp_path / "cache", _RENDER)
    assert cold["stats"].get("misses", 0) >= 4  # sample, eval, pdf and the tile kernel
    runtime = list((tmp_path / "cache").glob("*/numba/runtime-*.pickle"))
    assert len(runtime) == 1  # numba's runtime functions, compiled once for this machine
    warm = _run(tmp_path / "cache", _RENDER)
    assert warm["stats"].get("misses", 0) == 0 and warm["stats"].get("hits", 0) >= 4
    assert warm["stats"].get("errors", 0) == 0
    # every kernel loaded for its calls' types: no call had numba type its arguments first
    # (which scans every installed package for numba extensions), nor add a signature
    assert warm["extensions_scanned"] is False and warm["tile_signatures"] == 1
    # the scratch buffers are allocated in place (kernel_tools.empty): loading the machine
    # code rebuilds no environment of numba's array functions, so imports none of them
    assert warm["array_module"] is False
    np.testing.assert_array_equal(warm["f"], cold["f"])
    runtime[0].write_bytes(b"\x80\x04not a pickle")  # unreadable: compiled again, replaced
    again = _run(tmp_path / "cache", _RENDER)
    assert again["stats"].get("misses", 0) == 0 and again["stats"].get("errors", 0) == 0
    np.testing.assert_array_equal(again["f"], cold["f"])
    assert pickle.loads(runtime[0].read_bytes())[1] == "object"  # machine code written again


def test_the_version_reads_numbas_version_without_importing_numba():
    """The atlas's workers ask for the cache's version; importing numba for its version alone
    cost each of them ~0.3 s."""
    code = (
        "import sys; from brdfkit.compiled import cache as kernel_cache; kernel_cache.version(); "
        "print('numba' in sys.modules, 'importlib.metadata' in sys.modules)"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "False False"


def test_the_version_hashes_the_kernels_sources_and_not_the_applications():
    package = Path(kernel_cache.__file__).parents[1]
    expected = sorted(
        path.relative_to(package).as_posix()
        for path in package.rglob("*.py")
        if path.relative_to(package).parts[0] not in kernel_cache._APPLICATION
    )
    found = kernel_cache._kernel_sources(package)
    assert found == expected
    assert "compiled/cache.py" in found and "brdf/microfacet.py" in found
    assert not any(p.startswith(("cli/", "explore/")) or p == "plot.py" for p in found)


def test_the_version_is_computed_once_by_threads_asking_at_once(monkeypatch):
    """A render's kernels and its map's tables ask for it at the same moment."""
    import threading

    calls = []
    sources = kernel_cache._kernel_sources

    def slow_sources(package):
        calls.append(threading.get_ident())
        time.sleep(0.05)
        return sources(package)

    kernel_cache._version.cache_clear()
    monkeypatch.setattr(kernel_cache, "_kernel_sources", slow_sources)
    try:
        found = []
        threads = [
            threading.Thread(target=lambda: found.append(kernel_cache.version())) for _ in range(4)
        ]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    finally:
        kernel_cache._version.cache_clear()
    assert len(calls) == 1
    assert len(found) == 4 and len(set(found)) == 1
    assert found[0] == kernel_cache.version()
