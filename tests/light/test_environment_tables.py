"""An environment map's tables: the irradiance table against its direct quadrature, and the
caches that share tables between maps of equal pixels, in memory and on disk."""

import math
import threading

import numpy as np
import pytest

from brdfkit.compiled import cache
from brdfkit.light import EnvironmentMap, environment
from brdfkit.light.environment import (
    IRRADIANCE_CELLS,
    IRRADIANCE_GRID,
    clear_table_cache,
    wait_for_table_store,
)


def _direct_irradiance_table(image: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """The table's quadrature summed over every cell at the flat node indices ``nodes`` (the
    formula of :attr:`EnvironmentMap.irradiance_table`, written out independently)."""
    height, width, channels = image.shape
    rows, cols = IRRADIANCE_CELLS
    edges = np.arange(height + 1) * math.pi / height
    solid_angle = 2 * math.pi / width * (np.cos(edges[:-1]) - np.cos(edges[1:]))
    t, p = np.meshgrid(
        (np.arange(height) + 0.5) * math.pi / height,
        (np.arange(width) + 0.5) * 2 * math.pi / width,
        indexing="ij",
    )
    omega = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
    weighted = (omega * solid_angle[:, None, None]).reshape(-1, 3)
    cell = (np.arange(height) * rows // height)[:, None] * cols + np.arange(width) * cols // width
    cell = cell.ravel()

    def moments(values: np.ndarray) -> np.ndarray:  # (cells, 3)
        return np.stack([np.bincount(cell, values * w, rows * cols) for w in weighted.T], -1)

    vectors = [moments(np.ones(height * width))]
    vectors += [moments(image[..., c].ravel().astype(float)) for c in range(channels)]
    node_rows, node_cols = IRRADIANCE_GRID
    tn, pn = np.meshgrid(
        np.linspace(0, math.pi, node_rows), np.arange(node_cols) * 2 * math.pi / node_cols,
        indexing="ij",
    )  # fmt: skip
    normals = np.stack([np.sin(tn) * np.cos(pn), np.sin(tn) * np.sin(pn), np.cos(tn)], -1)
    normals = normals.reshape(-1, 3)[nodes]
    sums = [np.maximum(normals @ v.T, 0).sum(1) for v in vectors]
    return math.pi * np.stack(sums[1:], -1) / sums[0][:, None]


@pytest.fixture(params=["numpy", "numba"])
def sums_by(request, monkeypatch):
    """The irradiance table's sums over cells by NumPy, or by the numba kernel the compiled
    layer hands in (:func:`brdfkit.light.environment.compiled_lookups`)."""
    tools = []
    if request.param == "numba":
        pytest.importorskip("numba")
        from brdfkit.compiled import kernel_tools

        tools = [kernel_tools]
    monkeypatch.setattr(environment, "_KERNEL_TOOLS", tools)
    return request.param


@pytest.mark.parametrize("shape", [(100, 250), (24, 40)])
def test_irradiance_table_equals_the_direct_quadrature_over_every_cell(shape, sums_by):
    """Cells wholly above or below a normal's horizon summed by arcs equal the clamped sum
    over every cell: with a sun, uneven cells (100 × 250 pixels in 48 × 96 cells) and more
    cells than pixels (empty cells); by NumPy and by the numba kernel."""
    rng = np.random.default_rng(7)
    image = rng.random((*shape, 3)).astype(np.float32)
    image[shape[0] // 3, shape[1] // 5] = [5e4, 4e4, 3e4]  # a one-texel sun
    clear_table_cache()
    table = EnvironmentMap(image).irradiance_table.reshape(-1, 3)
    nodes = np.concatenate([np.arange(0, table.shape[0], 11), [table.shape[0] - 1]])  # poles too
    np.testing.assert_allclose(table[nodes], _direct_irradiance_table(image, nodes), rtol=2e-5)


def test_maps_of_equal_pixels_share_their_tables_and_others_do_not():
    rng = np.random.default_rng(3)
    image = rng.random((16, 32, 3))
    clear_table_cache()
    first = EnvironmentMap(image)
    again = EnvironmentMap(image.copy(), scale=2.0, rotation=np.diag([1.0, -1.0, -1.0]))
    assert again.irradiance_table is first.irradiance_table
    assert again.compensated._distribution is first.compensated._distribution
    assert again._distribution is first._distribution
    other = image.copy()
    other[5, 7, 1] += 0.25
    normal = np.array([[0.0, 0.0, 1.0]])
    assert not np.array_equal(EnvironmentMap(other).irradiance(normal), first.irradiance(normal))
    assert EnvironmentMap(other)._distribution is not first._distribution
    clear_table_cache()
    assert EnvironmentMap(image)._distribution is not first._distribution
    # scale and rotation are applied on top of the shared map-frame table
    np.testing.assert_allclose(again.irradiance(-normal), 2.0 * first.irradiance(normal), rtol=1e-6)


def test_irradiance_of_some_normals_equals_the_lookup_in_the_whole_table(sums_by):
    """Only the table's columns the normals read are built: the values are the same."""
    rng = np.random.default_rng(5)
    image = rng.random((24, 48, 3))
    normals = rng.normal(size=(200, 3))
    normals[:, 0] = np.abs(normals[:, 0])  # one side of the map: half the columns
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    clear_table_cache()
    partial = EnvironmentMap(image).irradiance(normals)
    clear_table_cache()
    whole = EnvironmentMap(image)
    _ = whole.irradiance_table
    np.testing.assert_array_equal(partial, whole.irradiance(normals))


@pytest.fixture
def table_dir(tmp_path, monkeypatch):
    """A disk cache of its own (:mod:`brdfkit.compiled.cache` is the maps' table store)."""
    monkeypatch.setenv(cache.ENV, str(tmp_path))
    clear_table_cache()
    yield tmp_path
    wait_for_table_store()
    clear_table_cache()


def _stored_tables(folder):
    wait_for_table_store()  # the tables are written in the background
    return sorted(folder.rglob("irradiance/*.npz"))


def _no_building(monkeypatch):
    def refuse(*args):
        raise AssertionError("the irradiance table was built, not read from disk")

    monkeypatch.setattr(environment, "_node_sums", refuse)


def test_a_new_process_reads_the_irradiance_table_from_disk_bit_equal(table_dir, monkeypatch):
    """The table is stored once built; with the in-memory cache gone (as in a new process) a
    map of the same pixels reads it back, equal to the bit, without building it."""
    image = np.random.default_rng(11).random((12, 24, 3)).astype(np.float32)
    built = EnvironmentMap(image).irradiance_table.copy()
    (path,) = _stored_tables(table_dir)
    clear_table_cache()
    _no_building(monkeypatch)
    np.testing.assert_array_equal(EnvironmentMap(image.copy()).irradiance_table, built)
    assert _stored_tables(table_dir) == [path]


def test_cells_grouped_ahead_give_the_same_irradiance_and_none_over_a_stored_table(
    table_dir, monkeypatch
):
    """prepare_irradiance groups a never-seen map's pixels into the cells before any lookup
    (which then groups none) for the same values; over a table read from disk, whose built
    columns may be all the lookups read, it groups nothing."""
    image = np.random.default_rng(13).random((12, 24, 3)).astype(np.float32)
    normals = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [-0.6, 0.0, -0.8]])
    expected = EnvironmentMap(image).irradiance(normals)
    for path in _stored_tables(table_dir):
        path.unlink()  # never seen again
    clear_table_cache()
    ahead = EnvironmentMap(image.copy())
    ahead.prepare_irradiance()

    def refuse(*args):
        raise AssertionError("the pixels were grouped into cells again")

    monkeypatch.setattr(environment, "_cell_moments", refuse)
    np.testing.assert_array_equal(ahead.irradiance(normals), expected)
    assert len(_stored_tables(table_dir)) == 1
    clear_table_cache()
    stored = EnvironmentMap(image.copy())
    stored.prepare_irradiance()
    np.testing.assert_array_equal(stored.irradiance(normals), expected)


def test_the_table_key_names_the_pixels(table_dir):
    image = np.random.default_rng(12).random((12, 24, 3)).astype(np.float32)
    other = image.copy()
    other[3, 4, 2] += 0.5
    key = EnvironmentMap(image)._table_key("irradiance")
    assert EnvironmentMap(image.copy())._table_key("irradiance") == key
    assert EnvironmentMap(other)._table_key("irradiance") != key
    assert EnvironmentMap(image[:, ::-1])._table_key("irradiance") != key
    assert EnvironmentMap(image)._table_key("weights") != key


def test_a_partial_table_on_disk_is_completed_and_stored_again(table_dir):
    """Columns built by lookups are stored with the mask of what was built; a later map
    builds only what is missing and stores the whole."""
    image = np.random.default_rng(13).random((12, 24, 3)).astype(np.float32)
    EnvironmentMap(image).irradiance(np.array([[1.0, 0.0, 0.0]]))
    (path,) = _stored_tables(table_dir)
    with np.load(path) as stored:
        assert 0 < stored["built"].sum() < IRRADIANCE_GRID[1]
    clear_table_cache()
    whole = EnvironmentMap(image).irradiance_table
    wait_for_table_store()
    with np.load(path) as stored:
        assert stored["built"].all()
        np.testing.assert_array_equal(stored["table"], whole)
    nodes = np.arange(0, whole[..., 0].size, 97)
    direct = _direct_irradiance_table(image, nodes)
    np.testing.assert_allclose(whole.reshape(-1, 3)[nodes], direct, rtol=2e-5)


def _truncate(path):
    path.write_bytes(path.read_bytes()[:300])


def _wrong_shape(path):
    np.savez(path, table=np.zeros((3, 4, 3), np.float32), built=np.ones(4, bool))


def _not_finite(path):
    with np.load(path) as stored:
        table, built = stored["table"].copy(), stored["built"]
    table[5, np.flatnonzero(built)[0], 1] = np.nan
    np.savez(path, table=table, built=built)


def _objects(path):
    np.savez(path, table=np.array([None], dtype=object), built=np.ones(1, bool))


@pytest.mark.parametrize("damage", [_truncate, _wrong_shape, _not_finite, _objects])
def test_a_bad_table_on_disk_is_built_again_and_replaced(table_dir, damage):
    """A truncated or corrupt file, one of another shape, with a NaN or holding objects is
    never trusted: the table's columns are built again (equal to the first) and the file
    replaced. (One normal's lookup: two columns, cheap.)"""
    image = np.random.default_rng(14).random((12, 24, 3)).astype(np.float32)
    normal = np.array([[0.6, 0.0, 0.8]])
    first = EnvironmentMap(image).irradiance(normal)
    (path,) = _stored_tables(table_dir)
    with np.load(path) as stored:
        built, table = stored["built"], stored["table"]
    damage(path)
    clear_table_cache()
    np.testing.assert_array_equal(EnvironmentMap(image).irradiance(normal), first)
    wait_for_table_store()
    with np.load(path) as stored:
        np.testing.assert_array_equal(stored["built"], built)
        np.testing.assert_array_equal(stored["table"], table)


def test_an_empty_cache_dir_keeps_the_tables_in_memory_only(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.ENV, "")
    monkeypatch.chdir(tmp_path)
    clear_table_cache()
    image = np.random.default_rng(15).random((12, 24, 3)).astype(np.float32)
    EnvironmentMap(image).irradiance(np.array([[0.0, 0.0, 1.0]]))
    clear_table_cache()
    assert cache.load_arrays("irradiance", EnvironmentMap(image)._table_key("irradiance")) is None
    assert list(tmp_path.iterdir()) == []


def test_only_the_irradiance_table_goes_to_the_store(table_dir):
    """A map's sampling distributions (plain and compensated) are made from its pixels, not
    looked up in the store nor written to it; its irradiance table is both."""
    store = environment.use_table_store(None)
    asked = []

    def load(kind, key):
        asked.append(("load", kind))
        return store.load(kind, key)

    def writer(kind, key):
        asked.append(("write", kind))
        return store.writer(kind, key)

    environment.use_table_store(environment.TableStore(load, writer))
    try:
        env = EnvironmentMap(np.random.default_rng(16).random((12, 24, 3)).astype(np.float32))
        env.pdf(np.zeros(3), np.array([0.0, 0.0, 1.0]))
        env.compensated.pdf(np.zeros(3), np.array([0.0, 0.0, 1.0]))
        env.irradiance(np.array([0.0, 0.0, 1.0]))
        wait_for_table_store()
    finally:
        environment.use_table_store(store)
    assert set(asked) == {("load", "irradiance"), ("write", "irradiance")}


@pytest.mark.parametrize("shape", [(2, 2), (5, 3), (17, 40)])
def test_the_texel_mean_is_the_bilinear_lookups_mean_over_the_texel(shape):
    """The sampling weights' texel mean equals the bilinear lookup (rows clamped, columns
    wrapping) averaged over each texel by the midpoint rule on 4 × 4 points, exact for
    its four bilinear quarters, on the smallest maps too."""
    height, width = shape
    values = np.random.default_rng(19).random(shape) ** 3
    k = 4
    offsets = (np.arange(k) + 0.5) / k - 0.5  # in texels, from each centre
    row = (np.arange(height)[:, None] + offsets).reshape(-1, 1)
    col = (np.arange(width)[:, None] + offsets).reshape(1, -1)
    row, col = np.broadcast_arrays(row, col)
    lookup = environment._bilinear(values[..., None], row, col)[..., 0]
    expected = lookup.reshape(height, k, width, k).mean(axis=(1, 3))
    np.testing.assert_allclose(environment._texel_mean(values), expected, rtol=1e-12)


@pytest.mark.parametrize("shape", [(2, 2), (5, 3), (17, 40)])
def test_the_neighbourhood_maximum_is_scipys_maximum_filter(shape):
    """The sampling weights' 3×3 maximum (rows clamped, columns wrapping) equals SciPy's
    ``maximum_filter`` with those modes, to the bit, on the smallest maps too."""
    from scipy.ndimage import maximum_filter

    values = np.random.default_rng(17).random(shape) ** 3
    expected = maximum_filter(values, size=3, mode=("nearest", "wrap"))
    np.testing.assert_array_equal(environment._neighbourhood_maximum(values), expected)


def test_tables_are_written_off_the_callers_thread_where_the_store_pointed(
    table_dir, tmp_path_factory, monkeypatch
):
    """A new map's tables are written by the store's writer thread, not by the thread that
    builds them (its first image does not wait for the disk), into the folder the store
    pointed at when they were built, even if it points elsewhere before the write."""
    store = environment.use_table_store(None)
    writers = []

    def recording_writer(kind, key):
        write = store.writer(kind, key)

        def recorded(arrays):
            writers.append(threading.current_thread())
            write(arrays)

        return recorded

    environment.use_table_store(environment.TableStore(store.load, recording_writer))
    try:
        image = np.random.default_rng(17).random((12, 24, 3)).astype(np.float32)
        EnvironmentMap(image).irradiance(np.array([[0.0, 0.0, 1.0]]))
        elsewhere = tmp_path_factory.mktemp("elsewhere")
        monkeypatch.setenv(cache.ENV, str(elsewhere))
        wait_for_table_store()
    finally:
        environment.use_table_store(store)
    assert writers and threading.current_thread() not in writers
    assert len(_stored_tables(table_dir)) == 1
    assert list(elsewhere.rglob("*.npz")) == []


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf, -1e-30])
def test_a_map_holding_a_value_that_is_not_radiance_is_refused(bad):
    """One NaN, infinite or negative value among the pixels is refused (a file's, naming
    the file: ``tests/test_faults.py``)."""
    from brdfkit.errors import ParameterError

    image = np.ones((4, 8, 3), np.float32)
    image[2, 5, 1] = bad
    with pytest.raises(ParameterError, match="finite, non-negative"):
        EnvironmentMap(image)


def test_the_node_columns_are_those_each_lookup_reads():
    """The irradiance table's columns a lookup needs are, for each fractional column, the
    one at or below it and the next (wrapping), sorted and unique; NaN and infinity read
    column 0 (as the lookup's arithmetic does), and a column past the table the last."""
    rng = np.random.default_rng(23)
    for cols in (2, 7, 192):
        col = rng.uniform(-3.0, cols + 3.0, 50)
        col[:3] = np.nan, np.inf, -np.inf
        clean = np.nan_to_num(col, nan=0.0, posinf=0.0)
        left = np.clip(np.floor(clean), 0, cols - 1).astype(np.int64)
        expected = np.union1d(left, (left + 1) % cols)
        np.testing.assert_array_equal(environment._node_columns(col, cols), expected)


def test_the_table_store_is_read_one_entry_at_a_time():
    """Threads looking tables up in the store (a new map's irradiance table on a helper
    thread and on the caller's) read it one at a time: reading an ``.npz`` parses its
    headers with ``ast.literal_eval``, which CPython 3.11 can fail on two threads at once."""
    lock, active, most = threading.Lock(), [0], [0]

    def load(kind, key):
        with lock:
            active[0] += 1
            most[0] = max(most[0], active[0])
        threading.Event().wait(0.01)
        with lock:
            active[0] -= 1

    previous = environment.use_table_store(environment.TableStore(load, lambda kind, key: None))
    try:
        threads = [
            threading.Thread(target=environment._load_table, args=("irradiance", str(i)))
            for i in range(4)
        ]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    finally:
        environment.use_table_store(previous)
    assert most[0] == 1
