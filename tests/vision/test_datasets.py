"""Photometric-stereo data sets: DiLiGenT round trip, psm layout, synthetic lights and shadows."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from brdfkit.errors import FormatError, ParameterError, ResourceError
from brdfkit.vision import datasets
from brdfkit.vision.photometric_stereo import sphere_normals


def _small(name: str = "ball") -> datasets.PhotometricStereoData:
    normals, mask = sphere_normals((20, 24), (11.5, 9.5), 8.0)
    lights = datasets.diligent_like_lights(3, 2, np.radians(30))
    intensities = np.linspace(0.5, 1.0, 18).reshape(6, 3)
    return datasets.render_synthetic(
        normals, mask, lights, albedo=[0.8, 0.6, 0.4], light_intensities=intensities, name=name
    )


def test_diligent_round_trip(tmp_path):
    data = _small()
    datasets.save_diligent(data, tmp_path / "ballPNG")
    raw = datasets.read_image(tmp_path / "ballPNG" / "002.png")
    assert raw.shape == (20, 24, 3)
    # The files hold the raw images (times the intensities), 16-bit.
    np.testing.assert_allclose(raw, data.images[1] * data.light_intensities[1], atol=1 / 65535)
    loaded = datasets.load_dataset(tmp_path / "ballPNG")
    assert loaded.name == "ball"
    np.testing.assert_array_equal(loaded.mask, data.mask)
    np.testing.assert_allclose(loaded.images, data.images, atol=2 / 65535)
    np.testing.assert_allclose(loaded.light_directions, data.light_directions, atol=1e-8)
    np.testing.assert_allclose(loaded.normals, data.normals)
    np.testing.assert_allclose(loaded.light_intensities, data.light_intensities, atol=1e-8)
    half = datasets.load_diligent(tmp_path / "ballPNG", step=2)
    assert half.images.shape == (6, 10, 12, 3)
    np.testing.assert_allclose(half.normals, data.normals[::2, ::2])


def test_psm_layout(shared_data):
    data = datasets.load_psm(shared_data / "photometric_stereo" / "psm" / "gray", step=4)
    assert data.images.shape == (12, 85, 128, 3)
    assert data.images.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(data.light_directions, axis=1), 1.0)
    assert np.all(data.light_directions[:, 2] > 0)  # lights face the object (z to the camera)
    np.testing.assert_allclose(np.linalg.norm(data.normals[data.mask], axis=1), 1.0, atol=1e-6)
    cat = datasets.load_dataset(shared_data / "photometric_stereo" / "psm" / "cat", step=4)
    assert cat.normals is None and cat.mask.any()


def test_diligent_like_lights():
    lights = datasets.diligent_like_lights()
    assert lights.shape == (96, 3)
    np.testing.assert_allclose(np.linalg.norm(lights, axis=1), 1.0)
    polar = np.degrees(np.arccos(lights[:, 2]))
    assert polar.max() == pytest.approx(45.0)
    assert lights[0, 0] < 0 and lights[0, 1] > 0  # first row: top left


def test_cast_shadows_of_a_wall():
    height = np.zeros((9, 9))
    height[:, 6] = 3.0  # a wall 3 pixels high in column 6
    towards_right = np.array([[1.0, 0.0, 1.0]])  # 45° elevation, to the right
    lit = datasets.cast_shadows(height, towards_right)[0]
    assert not lit[:, 4:6].any()  # less than 3 pixels left of the wall
    assert lit[:, :4].all() and lit[:, 6:].all()  # column 3 grazes the wall's top
    assert datasets.cast_shadows(height, np.array([[0.0, 0.0, 1.0]])).all()


def test_horizon_excess_of_a_wall_is_its_rise_above_each_ray():
    height = np.zeros((5, 9))
    height[:, 6] = 3.0
    towards_right = np.array([[1.0, 0.0, 1.0]])  # 45°: the ray rises one unit per pixel
    excess = datasets.horizon_excess(height, towards_right).reshape(5, 9)
    # The highest of the wall (3 - distance) and of the ground one pixel on (0 - 1); the
    # last column has nothing towards the light.
    expected = [-1.0, -1.0, -1.0, 0.0, 1.0, 2.0, -4.0, -1.0, -np.inf]
    np.testing.assert_allclose(excess, [expected] * 5)
    assert np.all(datasets.horizon_excess(height, [[0.0, 0.0, 1.0]]) == -np.inf)  # the zenith
    for bias in (0.0, 0.5, 1.0, 2.5):
        np.testing.assert_array_equal(
            datasets.cast_shadows(height, towards_right, bias=bias)[0], excess <= bias
        )


def test_cast_shadows_light_what_has_no_surface_and_march_only_over_it():
    height = np.full((7, 12), np.nan)
    height[2:5, 6:9] = 0.0
    height[2:5, 9] = 4.0  # a wall on the surface's right edge
    lit = datasets.cast_shadows(height, [[1.0, 0.0, 1.0]])[0]
    assert lit[~np.isfinite(height)].all()  # left of the surface, in the wall's line: lit
    np.testing.assert_array_equal(lit[2:5, 6:10], [[False, False, False, True]] * 3)
    excess = datasets.horizon_excess(height, [[1.0, 0.0, 1.0]])
    assert excess.shape == (1, 12)  # one value per surface pixel, row-major
    with pytest.raises(ValueError, match="no finite value"):
        datasets.horizon_excess(np.full((3, 3), np.nan), [[1.0, 0.0, 1.0]])


def test_bad_files_are_named(tmp_path):
    data = _small()
    folder = tmp_path / "ballPNG"
    datasets.save_diligent(data, folder)
    (folder / "003.png").write_bytes(b"not a png")
    with pytest.raises(ValueError, match=r"003\.png"):
        datasets.load_diligent(folder)
    with pytest.raises(ValueError, match="neither a DiLiGenT folder"):
        datasets.load_dataset(tmp_path)
    with pytest.raises(ValueError, match="does not exist"):
        datasets.load_dataset(tmp_path / "missing")
    (folder / "filenames.txt").write_text("001.png\n002.png\n")
    with pytest.raises(ValueError, match="at least 3 images"):
        datasets.load_diligent(folder)
    (folder / "filenames.txt").write_text("\n".join(f"{k:03d}.png" for k in (1, 2, 4, 5)))
    with pytest.raises(ValueError, match=r"light_directions\.txt has 6 rows"):
        datasets.load_diligent(folder)
    with pytest.raises(ValueError, match="mask"):
        datasets.PhotometricStereoData(data.images, data.light_directions, ~np.ones((20, 24), bool))


def _saved(tmp_path) -> Path:
    folder = tmp_path / "ballPNG"
    datasets.save_diligent(_small(), folder)
    return folder


@pytest.mark.parametrize(
    ("name", "content", "match"),
    [
        ("light_directions.txt", b"1 0 1\n0 1 1\nnan 0 1\n1 1 1\n0 0 1\n1 0 2\n", "line 3"),
        ("light_directions.txt", b"1 0 1\n0 1 1\n0 x 1\n1 1 1\n0 0 1\n1 0 2\n", "line 3"),
        ("light_directions.txt", b"1 0 1\n0 1\n0 0 1\n1 1 1\n0 0 1\n1 0 2\n", "line 2"),
        ("light_directions.txt", b"0 0 0\n0 1 1\n0 0 1\n1 1 1\n0 0 1\n1 0 2\n", "is zero"),
        ("light_directions.txt", b"\xff\xfe1 0 1\n", "not UTF-8"),
        ("light_intensities.txt", b"1 1 1\n" * 5, "has 5 rows"),
        ("light_intensities.txt", b"1 1 1\n" * 5 + b"1 inf 1\n", "line 6"),
        ("light_intensities.txt", b"1 1 1\n" * 5 + b"1 0 1\n", "positive"),
        ("filenames.txt", b"001.png\n002.png\n003.png\n004.png\n005.png\n\x80.png\n", "UTF-8"),
        ("filenames.txt", b"001.png\n002.png\n003.png\n004.png\n005.png\nnone.png\n", "none"),
        ("Normal_gt.mat", b"MATLAB 5.0 MAT-file, truncated", "Normal_gt.mat"),
    ],
)
def test_bad_diligent_files_raise_format_errors_naming_them(tmp_path, name, content, match):
    folder = _saved(tmp_path)
    (folder / name).write_bytes(content)
    with pytest.raises(FormatError, match=match) as caught:
        datasets.load_diligent(folder)
    assert name in str(caught.value) or "none.png" in str(caught.value)


def test_normal_gt_without_its_key_and_mismatched_files(tmp_path):
    import scipy.io

    # Regression: a Normal_gt.mat without the variable raised a bare KeyError.
    folder = _saved(tmp_path)
    scipy.io.savemat(folder / "Normal_gt.mat", {"normals": np.zeros((20, 24, 3))})
    with pytest.raises(FormatError, match=r"Normal_gt\.mat \(field 'Normal_gt'\)"):
        datasets.load_diligent(folder)
    scipy.io.savemat(folder / "Normal_gt.mat", {"Normal_gt": np.zeros((20, 23, 3))})
    with pytest.raises(FormatError, match="Normal_gt"):
        datasets.load_diligent(folder)
    nan_inside = np.zeros((20, 24, 3))
    nan_inside[10, 12] = np.nan
    scipy.io.savemat(folder / "Normal_gt.mat", {"Normal_gt": nan_inside})
    with pytest.raises(FormatError, match="NaN"):
        datasets.load_diligent(folder)
    (folder / "Normal_gt.mat").unlink()
    cv2 = pytest.importorskip("cv2")
    cv2.imwrite(str(folder / "mask.png"), np.full((10, 24), 255, np.uint8))
    with pytest.raises(FormatError, match=r"mask\.png"):
        datasets.load_diligent(folder)
    cv2.imwrite(str(folder / "004.png"), np.zeros((20, 25, 3), np.uint16))
    with pytest.raises(FormatError, match=r"004\.png.*shape"):
        datasets.load_diligent(folder)
    (folder / "mask.png").unlink()
    with pytest.raises(ParameterError, match="step"):
        datasets.load_diligent(folder, step=0)
    with pytest.raises(ResourceError, match="step"):
        datasets.load_diligent(folder, step=10**6)


def _psm(tmp_path, lights=b"3\n0 0 1\n0.1 0 1\n0 0.1 1\n", listing=None):
    """A tiny psm layout: three 8 × 6 TGA images and a mask."""
    from PIL import Image

    root = tmp_path / "psm"
    (root / "obj").mkdir(parents=True)
    rng = np.random.default_rng(0)
    for k in range(3):
        pixels = rng.integers(0, 256, (6, 8, 3), dtype=np.uint8)
        Image.fromarray(pixels).save(root / "obj" / f"obj.{k}.tga")
    Image.fromarray(np.full((6, 8, 3), 255, np.uint8)).save(root / "obj" / "obj.mask.tga")
    entries = [f"psmImages/obj/obj.{k}.tga" for k in range(3)] + ["psmImages/obj/obj.mask.tga"]
    (root / "obj.txt").write_bytes(listing or ("3\n" + "\n".join(entries) + "\n").encode())
    (root / "lights.txt").write_bytes(lights)
    return root / "obj"


def test_psm_loader_reads_a_small_layout_and_names_bad_files(tmp_path):
    data = datasets.load_psm(_psm(tmp_path / "good"))
    assert data.images.shape == (3, 6, 8, 3)
    with pytest.raises(FormatError, match=r"lights\.txt.*line 1"):
        datasets.load_psm(_psm(tmp_path / "a", lights=b"three\n0 0 1\n0.1 0 1\n0 0.1 1\n"))
    with pytest.raises(FormatError, match=r"lights\.txt.*says 4 rows"):
        datasets.load_psm(_psm(tmp_path / "b", lights=b"4\n0 0 1\n0.1 0 1\n0 0.1 1\n"))
    with pytest.raises(FormatError, match=r"lights\.txt.*line 3"):
        datasets.load_psm(_psm(tmp_path / "c", lights=b"3\n0 0 1\n0.1 nan 1\n0 0.1 1\n"))
    with pytest.raises(FormatError, match=r"obj\.txt.*line 1"):
        datasets.load_psm(_psm(tmp_path / "d", listing=b"x\na b c d\n"))
    with pytest.raises(FormatError, match=r"obj\.txt.*count"):
        datasets.load_psm(_psm(tmp_path / "e", listing=b"7\na b c d\n"))
    folder = _psm(tmp_path / "f")
    (folder / "obj.mask.tga").write_bytes(b"TGA?")
    with pytest.raises(FormatError, match=r"obj\.mask\.tga"):
        datasets.load_psm(folder)
    with pytest.raises(ParameterError, match="light_directions"):
        datasets.load_psm(_psm(tmp_path / "g"), light_directions=np.full((3, 3), np.nan))


def test_read_normal_map_npy_and_png(tmp_path):
    normals, _ = sphere_normals((6, 7), (3.0, 2.5), 3.0)
    np.save(tmp_path / "n.npy", normals.astype(np.float32))
    loaded = datasets.read_normal_map(tmp_path / "n.npy")
    assert loaded.dtype == np.float64
    np.testing.assert_allclose(loaded, normals, atol=1e-7)
    datasets.write_normal_map(tmp_path / "n.png", normals)
    np.testing.assert_allclose(datasets.read_normal_map(tmp_path / "n.png"), normals, atol=2e-5)
    # Regression: a pickled or truncated .npy gave an UnpicklingError / ValueError traceback.
    np.save(tmp_path / "pickled.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    (tmp_path / "cut.npy").write_bytes((tmp_path / "n.npy").read_bytes()[:-20])
    (tmp_path / "empty.npy").write_bytes(b"")
    np.save(tmp_path / "flat.npy", np.zeros((6, 7)))
    bad = normals.copy()
    bad[1, 1, 0] = np.inf
    np.save(tmp_path / "inf.npy", bad)
    for name in ("pickled", "cut", "empty", "flat", "inf", "missing"):
        with pytest.raises(FormatError, match=f"{name}.npy"):
            datasets.read_normal_map(tmp_path / f"{name}.npy")
    with pytest.raises(ParameterError, match="normals"):
        datasets.write_normal_map(tmp_path / "x.png", bad)


def test_a_16_bit_normal_map_is_decoded_exactly_and_read_for_integration_as_stored(tmp_path):
    """Each 16-bit code ``v`` gives ``2 v / 65535 - 1`` in float64 to the last bit (no float32
    step), and what ``brdfkit integrate`` reads keeps the stored length (not renormalised)."""
    from brdfkit.vision.depth_from_normals import read_normal_map_input

    normals, _ = sphere_normals((6, 7), (3.0, 2.5), 3.0)
    normals[0, 0] = [0.0, 0.0, 1.0]
    datasets.write_normal_map(tmp_path / "n.png", normals)
    codes = np.round(65535 * (normals + 1) / 2)
    decoded = datasets.read_normal_map(tmp_path / "n.png")
    np.testing.assert_array_equal(decoded, 2.0 * codes / 65535 - 1.0)
    assert decoded[0, 0, 2] == 1.0
    stored = read_normal_map_input(tmp_path / "n.png")
    inside = stored.mask
    np.testing.assert_array_equal(stored.normals[inside], decoded[inside])
    assert np.ptp(np.linalg.norm(stored.normals[inside], axis=-1)) > 1e-6


def test_light_directions_with_extreme_components_are_normalised(tmp_path):
    # Found by fuzzing: a component of 1e308 overflowed the length, giving a zero direction.
    folder = _saved(tmp_path)
    rows = datasets.diligent_like_lights(3, 2, np.radians(30))
    rows[0] *= 1e308 / np.abs(rows[0]).max()
    rows[1] *= 1e-320 / np.abs(rows[1]).max()
    np.savetxt(folder / "light_directions.txt", rows)
    lights = datasets.load_diligent(folder).light_directions
    np.testing.assert_allclose(np.linalg.norm(lights, axis=1), 1.0)


def test_normal_gt_mat_reader_matches_scipy_and_refuses_corrupt_files(tmp_path):
    import scipy.io

    normals = np.random.default_rng(0).normal(size=(5, 7, 3))
    path = tmp_path / "Normal_gt.mat"
    for compressed in (False, True):
        variables = {"note": "text", "Normal_gt": normals.astype(np.float32), "n": 3}
        scipy.io.savemat(path, variables, do_compression=compressed)
        expected = scipy.io.loadmat(path)["Normal_gt"].astype(np.float64)
        np.testing.assert_array_equal(datasets._read_mat_array(path, "Normal_gt"), expected)
    # Found by fuzzing: scipy.io.loadmat crashed the interpreter on such files.
    scipy.io.savemat(path, {"Normal_gt": normals})
    data = bytearray(path.read_bytes())
    data[204:208] = (10**6).to_bytes(4, "little")  # the size of the array's data
    path.write_bytes(bytes(data))
    with pytest.raises(FormatError, match=r"Normal_gt\.mat"):
        datasets._read_mat_array(path, "Normal_gt")
    path.write_bytes(bytes(data[:300]))
    with pytest.raises(FormatError, match="runs past the end"):
        datasets._read_mat_array(path, "Normal_gt")


def test_read_depth_map_keeps_unknown_depths_and_refuses_what_is_no_depth(tmp_path):
    from brdfkit.io import write_image

    depth = np.array([[1.0, np.nan], [2.5, 3.0]])
    write_image(tmp_path / "d.exr", depth[..., None].astype(np.float32), nan_marks_missing=True)
    np.save(tmp_path / "d.npy", depth)
    for name in ("d.exr", "d.npy"):
        np.testing.assert_array_equal(datasets.read_depth_map(tmp_path / name), depth)
    np.save(tmp_path / "rgb.npy", np.ones((2, 2, 3)))
    write_image(tmp_path / "d.png", np.ones((2, 2, 1)), srgb=False)
    for name, message in (("rgb.npy", r"shape \(H, W\)"), ("d.png", "must be .npy or a float")):
        with pytest.raises(FormatError, match=message):
            datasets.read_depth_map(tmp_path / name)


def test_perspective_sphere_depth_is_what_its_normals_integrate_to():
    """The sphere's normals and depth agree in the frame of the integrators: least squares
    in perspective returns its depth after one scale within 0.5 % of its relief on average
    (the silhouette's grazing pixels left out of the score), and each pixel's point lies on
    the sphere."""
    from brdfkit.vision.normal_integration import least_squares_integration

    camera = np.array([[500.0, 0, 30.0], [0, 520.0, 25.0], [0, 0, 1]])
    ball = datasets.perspective_sphere((56, 64), camera, centre=(1.0, -0.5, -60.0), radius=4.0)
    rows, columns = np.indices(ball.mask.shape)
    rays = np.stack(
        [(columns - 30.0) / 500.0, (25.0 - rows) / 520.0, -np.ones(ball.mask.shape)], axis=-1
    )
    points = ball.depth[ball.mask][:, None] * rays[ball.mask]
    np.testing.assert_allclose(np.linalg.norm(points - [1.0, -0.5, -60.0], axis=1), 4.0)
    depth = least_squares_integration(ball.normals, ball.mask, camera)
    inner = ball.mask & (ball.normals[..., 2] > 0.5)
    scale = np.median(ball.depth[inner] / depth[inner])
    error = np.abs(scale * depth[inner] - ball.depth[inner])
    assert error.mean() < 0.005 * np.ptp(ball.depth[inner])  # 0.23 %; 37 % with y flipped


@pytest.mark.parametrize(
    ("arguments", "error"),
    [
        (((8, 8), np.eye(3), (0.0, 0.0, 5.0), 1.0), ParameterError),  # behind the camera
        (((8, 8), np.eye(3), (0.0, 0.0, -1.0), 2.0), ParameterError),  # around it
        (((8, 8), np.eye(3), (0.0, -1.0), 1.0), ParameterError),
        (((8, 8), np.eye(3), (0.0, 0.0, -5.0), 0.0), ParameterError),
        (((8, 8), -np.eye(3), (0.0, 0.0, -5.0), 1.0), ParameterError),
        (((8,), np.eye(3), (0.0, 0.0, -5.0), 1.0), ParameterError),
        (((2**15, 2**15), np.eye(3), (0.0, 0.0, -5.0), 1.0), ResourceError),
    ],
)
def test_perspective_sphere_refuses_what_is_no_sphere_before_a_camera(arguments, error):
    with pytest.raises(error):
        datasets.perspective_sphere(*arguments)


def test_mat_reader_reads_what_matlab_itself_wrote():
    """SciPy's own test data: real numeric arrays written by MATLAB 6.1 to 7.4 (plain and
    compressed, both byte orders) and by a writer that stores the dimensions as miUINT32;
    MATLAB 7.3's HDF5 format is refused naming the file."""
    import scipy
    import scipy.io

    folder = Path(scipy.__file__).parent / "io" / "matlab" / "tests" / "data"
    files = sorted(folder.glob("*_[5-7].*.mat")) + sorted(folder.glob("miuint32_for_miint32.mat"))
    if not files:
        pytest.skip(f"SciPy's MATLAB test files are not installed in {folder}")
    checked = 0
    for path in files:
        if path.name.startswith("testhdf5"):  # MATLAB 7.3: HDF5, refused by name
            with pytest.raises(FormatError, match=path.name):
                datasets._read_mat_array(path, "a")
            continue
        for key, value in scipy.io.loadmat(path).items():
            if isinstance(value, np.ndarray) and value.dtype.kind in "fiu" and value.ndim >= 2:
                read = datasets._read_mat_array(path, key)
                np.testing.assert_array_equal(read, value.astype(np.float64), err_msg=path.name)
                checked += 1
    assert checked >= 10


def test_masks_read_alike_however_stored(tmp_path):
    """0/255, 0/1 (8 and 16 bits), colour, a cut-out's alpha and an opaque alpha give the same
    mask; an all-black mask has no pixel set (the 0/1 masks used to read as empty)."""
    cv2 = pytest.importorskip("cv2")
    from brdfkit.io import write_image

    mask = np.zeros((6, 8), bool)
    mask[1:4, 2:7] = True
    stored = {
        "255.png": mask.astype(np.uint8) * 255,
        "one.png": mask.astype(np.uint8),
        "one16.png": mask.astype(np.uint16),
        "colour.png": np.dstack([mask.astype(np.uint8) * 200] * 3),
        "cutout.png": np.dstack([np.full(mask.shape, 255, np.uint8)] * 3 + [mask * 255]),
        "opaque.png": np.dstack([mask.astype(np.uint8) * 255] * 3 + [np.full(mask.shape, 255)]),
    }
    for name, codes in stored.items():
        cv2.imwrite(str(tmp_path / name), codes.astype(codes.dtype))
        np.testing.assert_array_equal(datasets.read_mask(tmp_path / name), mask, err_msg=name)
    cv2.imwrite(str(tmp_path / "black.png"), np.zeros((6, 8), np.uint8))
    assert not datasets.read_mask(tmp_path / "black.png").any()
    write_image(
        tmp_path / "nan.exr", np.full((6, 8, 1), np.nan, np.float32), nan_marks_missing=True
    )
    with pytest.raises(FormatError, match="NaN"):
        datasets.read_mask(tmp_path / "nan.exr")
