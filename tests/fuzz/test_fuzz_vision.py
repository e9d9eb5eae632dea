"""Fuzz the vision readers: DiLiGenT and psm folders with one file mutated, normal and depth
maps.

Each target builds a small valid data set once, then every case writes a byte-mutated copy of
one of its files in place (text files with token mutations too), loads the folder through
:func:`_fuzzing.run_case` and restores the file. A load that succeeds must give finite images,
lights and normals.
"""

from __future__ import annotations

import functools
import tempfile
from pathlib import Path

import numpy as np
import pytest
from _fuzzing import fuzz_settings, mutated, run_case
from hypothesis import given
from hypothesis import strategies as st

from brdfkit.vision import datasets
from brdfkit.vision.photometric_stereo import sphere_normals

PSM = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "photometric_stereo" / "psm"
TEXT_SUFFIXES = (".txt",)


def _snapshot(root: Path) -> dict[str, bytes]:
    """Every file under ``root`` by relative path."""
    return {
        str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()
    }


@functools.cache
def _diligent() -> tuple[Path, dict[str, bytes]]:
    """A 12 × 10, 4-light DiLiGenT folder with intensities and Normal_gt.mat."""
    root = Path(tempfile.mkdtemp(prefix="fuzz_diligent_")) / "ballPNG"
    normals, mask = sphere_normals((10, 12), (5.5, 4.5), 4.0)
    lights = datasets.diligent_like_lights(2, 2, np.radians(30))
    data = datasets.render_synthetic(
        normals, mask, lights, albedo=[0.8, 0.6, 0.4], light_intensities=np.full((4, 3), 0.9)
    )
    datasets.save_diligent(data, root)
    return root, _snapshot(root)


@functools.cache
def _psm() -> tuple[Path, dict[str, bytes]]:
    """Four images, the mask and the lights of the real psm "gray" sphere, cropped to the
    sphere and subsampled to about 40 × 40 pixels (TGA, as the set stores them)."""
    from PIL import Image

    from brdfkit.io import read_image

    if not PSM.is_dir():
        pytest.skip(f"shared data not found at {PSM}")
    root = Path(tempfile.mkdtemp(prefix="fuzz_psm_")) / "psm"
    (root / "gray").mkdir(parents=True)
    mask = read_image(PSM / "gray" / "gray.mask.tga")
    rows, columns = np.nonzero(mask.max(axis=2) > 0.5)
    crop = np.s_[rows.min() - 4 : rows.max() + 5 : 6, columns.min() - 4 : columns.max() + 5 : 6]
    names = [f"gray.{k}.tga" for k in range(4)] + ["gray.mask.tga"]
    for name in names:
        pixels = np.round(read_image(PSM / "gray" / name)[crop] * 255).astype(np.uint8)
        Image.fromarray(pixels[..., :3]).save(root / "gray" / name)
    entries = "\n".join(f"psmImages/gray/{name}" for name in names)
    (root / "gray.txt").write_text(f"4\n{entries}\n")
    light_rows = (PSM / "lights.txt").read_text().splitlines()[1:5]
    (root / "lights.txt").write_text("4\n" + "\n".join(light_rows) + "\n")
    return root / "gray", _snapshot(root)


def _check_loaded(data: datasets.PhotometricStereoData | None) -> None:
    if data is None:
        return
    assert np.all(np.isfinite(data.images))
    assert np.all(np.isfinite(data.light_directions))
    np.testing.assert_allclose(np.linalg.norm(data.light_directions, axis=1), 1.0)
    if data.normals is not None:
        assert np.all(np.isfinite(data.normals))
    if data.light_intensities is not None:
        assert np.all(np.isfinite(data.light_intensities) & (data.light_intensities > 0))


def _fuzz_folder(target: str, root: Path, base: Path, seeds: dict[str, bytes], draw) -> None:
    """Mutate one file of the set under ``base``, load ``root``, restore the file."""
    name = draw(st.sampled_from(sorted(seeds)))
    blob = draw(mutated([seeds[name]], text=name.endswith(TEXT_SUFFIXES)))
    path = base / name
    path.write_bytes(blob)
    try:
        _check_loaded(run_case(target, datasets.load_dataset, root))
    finally:
        path.write_bytes(seeds[name])


@fuzz_settings(ci_cases=700)
@given(st.data())
def test_fuzz_diligent(data):
    root, seeds = _diligent()
    _fuzz_folder("diligent", root, root, seeds, data.draw)


@fuzz_settings(ci_cases=700)
@given(st.data())
def test_fuzz_psm(data):
    root, seeds = _psm()
    _fuzz_folder("psm", root, root.parent, seeds, data.draw)


@functools.cache
def _normal_maps() -> tuple[Path, dict[str, bytes]]:
    """A float32 and a float64 ``.npy`` and a 16-bit PNG of a small sphere's normals."""
    root = Path(tempfile.mkdtemp(prefix="fuzz_normal_map_"))
    normals, _ = sphere_normals((9, 11), (5.0, 4.0), 4.0)
    np.save(root / "f32.npy", normals.astype(np.float32))
    np.save(root / "f64.npy", normals)
    datasets.write_normal_map(root / "map.png", normals)
    return root, _snapshot(root)


def _read_mutated(target: str, reader, files: tuple[Path, dict[str, bytes]], draw):
    """``reader`` on a byte-mutated copy of one of ``files`` (a folder and its seeds) through
    :func:`_fuzzing.run_case`: its result, or ``None`` for a documented error."""
    root, seeds = files
    name = draw(st.sampled_from(sorted(seeds)))
    path = root / f"case{Path(name).suffix}"
    path.write_bytes(draw(mutated([seeds[name]])))
    return run_case(target, reader, path)


@fuzz_settings(ci_cases=1500)
@given(st.data())
def test_fuzz_normal_map(data):
    normals = _read_mutated("normal_map", datasets.read_normal_map, _normal_maps(), data.draw)
    if normals is not None:
        assert normals.dtype == np.float64 and normals.ndim == 3 and normals.shape[2] == 3
        assert np.all(np.isfinite(normals))


@functools.cache
def _depth_maps() -> tuple[Path, dict[str, bytes]]:
    """A float32 and a float64 ``.npy`` and an EXR of a small depth map, NaN outside a disc."""
    from brdfkit.io import write_image

    root = Path(tempfile.mkdtemp(prefix="fuzz_depth_map_"))
    _, mask = sphere_normals((9, 11), (5.0, 4.0), 4.0)
    depth = np.where(mask, 1500.0 + np.arange(99.0).reshape(9, 11), np.nan)
    np.save(root / "f32.npy", depth.astype(np.float32))
    np.save(root / "f64.npy", depth)
    write_image(root / "map.exr", depth[..., None].astype(np.float32), nan_marks_missing=True)
    return root, _snapshot(root)


@fuzz_settings(ci_cases=500)
@given(st.data())
def test_fuzz_depth_map(data):
    depth = _read_mutated("depth_map", datasets.read_depth_map, _depth_maps(), data.draw)
    if depth is not None:
        assert depth.dtype == np.float64 and depth.ndim == 2 and depth.size > 0
