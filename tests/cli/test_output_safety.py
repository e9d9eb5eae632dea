"""Every command that writes files keeps the user's data.

For each subcommand with ``-o``: an existing folder holding an unrelated file keeps it
byte-identical; ``-o`` equal to (or inside) an input is refused and the input is unchanged; a
name that is not UTF-8 works or is refused, never crashes; an unwritable place is refused before
the work, leaving nothing behind; outputs follow the umask (never 0600); errors go to stderr.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from brdfkit.brdf import Lambertian
from brdfkit.cli import app
from brdfkit.cli._output import MANIFEST
from brdfkit.io import write_image
from brdfkit.light import DirectionalLight
from brdfkit.measured import write_merl
from brdfkit.render import Sphere, gbuffer, shade
from brdfkit.vision import datasets
from brdfkit.vision.photometric_stereo import sphere_normals

runner = CliRunner()


@dataclass(frozen=True)
class Case:
    """How to run one subcommand on small inputs."""

    args: tuple[str, ...]
    """The command line without ``-o``."""
    inputs: tuple[Path, ...]
    """Every input file or folder it reads."""
    output: str
    """``"folder"``, or the extension of the output file."""


def _sphere(root: Path) -> tuple[Path, Path, Path]:
    """A Lambertian sphere under a directional light (.exr), its normals (.npy, .png) and mask."""
    g = gbuffer(Sphere(), None, 24)
    light = DirectionalLight(np.array([0.3, 0.2, 0.93]), 3.0)
    image = shade(g, Lambertian(0.6), [light], samples=1)
    write_image(root / "sphere.exr", np.repeat(image, 3, axis=-1).astype(np.float32))
    np.save(root / "normals.npy", g.normals)
    datasets.write_normal_map(root / "normals.png", np.where(g.mask[..., None], g.normals, 0))
    write_image(root / "mask.png", g.mask.astype(np.float32), srgb=False)
    return root / "sphere.exr", root / "normals.npy", root / "mask.png"


def _cases(root: Path) -> dict[str, Case]:
    root.mkdir()
    sphere, normals, mask = _sphere(root)
    normal_png = root / "normals.png"
    ball_normals, ball_mask = sphere_normals((20, 24), (11.5, 9.5), 8.0)
    lights = datasets.diligent_like_lights(3, 3, np.radians(25))
    lit = ball_mask & np.all(ball_normals @ lights.T > 0, axis=-1)
    ball = root / "ballPNG"
    datasets.save_diligent(
        datasets.render_synthetic(ball_normals, lit, lights, albedo=[0.6, 0.5, 0.4]), ball
    )
    measured = root / "grey.binary"
    write_merl(measured, Lambertian(0.5))
    exposures = []
    ramp = np.linspace(0.0, 1.0, 32 * 32 * 3).reshape(32, 32, 3)
    for k, time in enumerate((1.0, 4.0, 16.0)):
        path = root / f"exposure{k}.png"
        write_image(path, np.clip(ramp * time, 0, 1), srgb=False)
        exposures.append(path)
    return {
        "ps": Case(("ps", str(ball), "--method", "least_squares"), (ball,), "folder"),
        "fit": Case(
            ("fit", str(measured), "--model", "lambertian", "--starts", "1", "-r", "16"),
            (measured,),
            "folder",
        ),
        "render": Case(
            ("render", str(normal_png), "--mask", str(mask), "-s", "1", "-l", "directional:0,0,1"),
            (normal_png, mask),
            ".png",
        ),
        "hdr": Case(("hdr", *map(str, exposures), "--times", "1,4,16"), tuple(exposures), ".exr"),
        "lighting": Case(
            ("lighting", str(sphere), "--normals", str(normals), "--mask", str(mask)),
            (sphere, normals, mask),
            ".json",
        ),
        "separate": Case(("separate", str(sphere)), (sphere,), "folder"),
        "sfs": Case(("sfs", str(sphere), "--light", "0.3,0.2,0.93"), (sphere,), "folder"),
        "atlas": Case(
            ("atlas", "--models", "lambertian", "-r", "16", "-s", "1", "--no-checks"),
            (),
            "folder",
        ),
        "plot": Case(("plot", "lobe", "lambertian"), (), ".png"),
    }


COMMANDS = ("ps", "fit", "render", "hdr", "lighting", "separate", "sfs", "atlas", "plot")


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, Case]:
    return _cases(tmp_path_factory.mktemp("safety") / "inputs")


def _run(case: Case, output: Path | str):
    return runner.invoke(app, [*case.args, "-o", str(output)])


def _tree(path: Path) -> dict[str, str]:
    """Every file under ``path`` (or ``path`` itself) with its SHA-256 and mode."""
    files = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())
    return {
        os.fsdecode(p): hashlib.sha256(p.read_bytes()).hexdigest() + oct(p.stat().st_mode)
        for p in files
    }


def _target(case: Case, folder: Path, name: str = "out") -> Path:
    return folder / name if case.output == "folder" else folder / f"{name}{case.output}"


def _leftovers(folder: Path) -> list[str]:
    return [p.name for p in folder.rglob(".brdfkit-*") if p.name != MANIFEST]


@pytest.mark.slow
@pytest.mark.parametrize("command", COMMANDS)
def test_an_unrelated_file_in_the_output_folder_is_kept(inputs, tmp_path, command):
    case = inputs[command]
    folder = tmp_path / "results"
    folder.mkdir()
    keep = folder / "keep.txt"
    keep.write_bytes(b"the user's notes\n")
    before = _tree(folder)
    if case.output == "folder":
        result = _run(case, folder)
        assert result.exit_code == 0, result.output
        assert len(list(folder.iterdir())) > 2  # keep.txt, the manifest and the outputs
    else:
        refused = _run(case, folder)  # an existing folder where a file is wanted
        assert refused.exit_code == 2 and "existing folder" in refused.stderr
        result = _run(case, folder / f"out{case.output}")
        assert result.exit_code == 0, result.output
    assert {k: v for k, v in _tree(folder).items() if k in before} == before
    assert _leftovers(folder) == []


@pytest.mark.slow
@pytest.mark.parametrize("command", COMMANDS)
def test_outputs_follow_the_umask(inputs, tmp_path, command):
    case = inputs[command]
    previous = os.umask(0o022)
    try:
        result = _run(case, _target(case, tmp_path))
    finally:
        os.umask(previous)
    assert result.exit_code == 0, result.output
    modes = {p.name: p.stat().st_mode & 0o777 for p in tmp_path.rglob("*") if p.is_file()}
    assert modes and set(modes.values()) == {0o644}, modes


@pytest.mark.parametrize("command", [c for c in COMMANDS if c not in ("atlas", "plot")])
def test_an_output_equal_to_an_input_is_refused(inputs, command):
    case = inputs[command]
    before = {str(p): _tree(p) for p in case.inputs}
    for source in case.inputs:
        result = _run(case, source)
        assert result.exit_code == 2, (source, result.output)
        assert "error:" in result.stderr and "error" not in result.stdout
        assert {str(p): _tree(p) for p in case.inputs} == before


def test_an_output_inside_an_input_folder_is_refused(inputs):
    case = inputs["ps"]
    (folder,) = case.inputs
    before = _tree(folder)
    result = _run(case, folder / "results")
    assert result.exit_code == 2 and "inside the input folder" in result.stderr
    assert _tree(folder) == before and not (folder / "results").exists()


def test_rerunning_into_the_same_folder_replaces_only_its_own_files(inputs, tmp_path):
    case = inputs["separate"]
    folder = tmp_path / "out"
    assert _run(case, folder).exit_code == 0
    assert _run(case, folder).exit_code == 0  # brdfkit wrote these files: replacing is fine
    (folder / "diffuse.exr").write_bytes(b"the user's own diffuse.exr")
    result = _run(case, folder)
    assert result.exit_code == 2 and "did not write" in result.stderr
    assert (folder / "diffuse.exr").read_bytes() == b"the user's own diffuse.exr"


@pytest.mark.slow
@pytest.mark.parametrize("command", COMMANDS)
def test_non_utf8_output_names_work(inputs, tmp_path, command):
    case = inputs[command]
    name = os.fsdecode(b"r\xe9sultat-\xff")  # Latin-1 bytes: not valid UTF-8
    result = _run(case, _target(case, tmp_path, name))
    assert result.exit_code == 0, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit)
    assert "\\xff" in result.stdout  # the name is shown escaped, not as mojibake or a crash
    assert _leftovers(tmp_path) == []


@pytest.mark.parametrize("command", COMMANDS)
@pytest.mark.parametrize("place", ["below a file", "in /proc"])
def test_an_unwritable_output_is_refused_before_the_work(inputs, tmp_path, command, place):
    case = inputs[command]
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    parent = blocker if place == "below a file" else Path("/proc")
    target = _target(case, parent, "brdfkit-cannot-write-here")
    result = _run(case, target)
    assert result.exit_code == 2, result.output
    assert "cannot be written" in result.stderr and result.stdout == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file"]


def test_a_folder_output_that_is_an_existing_file_is_refused(inputs, tmp_path):
    case = inputs["sfs"]
    path = tmp_path / "notes.txt"
    path.write_text("keep me")
    result = _run(case, path)
    assert result.exit_code == 2 and "existing file; expected a folder" in result.stderr
    assert path.read_text() == "keep me"


@pytest.mark.slow
def test_the_real_entry_point_with_a_non_utf8_name(tmp_path):
    """A name that is not UTF-8 is written by the real process, not only by the test runner:
    run the console script itself (a crash there is a signal, such as SIGSEGV, rc 139)."""
    name = b"\xff.png"
    command = [sys.executable, "-c", "from brdfkit.cli import main; main()"]
    args = ["render", "-r", "8", "-s", "1", "--light", "directional:0,0,1", "-o"]
    done = subprocess.run(
        [*command, *args, name], cwd=tmp_path, capture_output=True, timeout=300, check=False
    )
    assert done.returncode == 0, done.stderr
    assert os.listdir(os.fsencode(tmp_path)) == [name]


def test_lighting_never_overwrites_its_input_image(inputs):
    case = inputs["lighting"]
    sphere = case.inputs[0]
    before = _tree(sphere)
    result = runner.invoke(app, ["lighting", str(sphere), "-m", "mirror-ball", "-o", str(sphere)])
    assert result.exit_code == 2 and "is an input" in result.stderr
    assert _tree(sphere) == before


def test_hdr_response_never_replaces_a_folder(inputs, tmp_path):
    case = inputs["hdr"]
    folder = tmp_path / "curves"
    folder.mkdir()
    (folder / "keep.txt").write_text("mine")
    result = runner.invoke(
        app, [*case.args, "-o", str(tmp_path / "m.exr"), "--response", str(folder)]
    )
    assert result.exit_code == 2 and "existing folder" in result.stderr
    assert (folder / "keep.txt").read_text() == "mine" and not (tmp_path / "m.exr").exists()


def test_a_file_that_appears_during_the_work_is_not_replaced(tmp_path):
    from brdfkit.cli._output import OutputFolder
    from brdfkit.errors import OutputError

    folder = OutputFolder(tmp_path / "out", ("result.txt",))
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "result.txt").write_text("written by someone else meanwhile")
    with pytest.raises(OutputError, match="did not write"):
        folder.write("result.txt", lambda path: path.write_text("ours"))
    assert (tmp_path / "out" / "result.txt").read_text() == "written by someone else meanwhile"


@pytest.mark.parametrize(
    "foreign", ["my notes, not JSON", '{"files": {"a.txt": "x"}}', "[1, 2]", '{"written_by": 3}']
)
def test_a_manifest_brdfkit_did_not_write_is_kept(tmp_path, foreign):
    """A user's own .brdfkit-outputs.json (not JSON) was overwritten with brdfkit's manifest."""
    from brdfkit.cli._output import OutputFolder
    from brdfkit.errors import OutputError

    (tmp_path / "out").mkdir()
    (tmp_path / "out" / MANIFEST).write_text(foreign)
    with pytest.raises(OutputError, match=f"holds {MANIFEST}, which brdfkit did not write"):
        OutputFolder(tmp_path / "out", ("result.txt",))
    assert (tmp_path / "out" / MANIFEST).read_text() == foreign
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [MANIFEST]


def test_a_manifest_that_appears_during_the_work_is_kept(tmp_path):
    from brdfkit.cli._output import OutputFolder
    from brdfkit.errors import OutputError

    folder = OutputFolder(tmp_path / "out", ("a.txt", "b.txt"))
    folder.write("a.txt", lambda path: path.write_text("ours"))
    (tmp_path / "out" / MANIFEST).write_text("someone else's")
    with pytest.raises(OutputError, match="did not write"):
        folder.write("b.txt", lambda path: path.write_text("ours too"))
    assert (tmp_path / "out" / MANIFEST).read_text() == "someone else's"


def test_a_full_disk_error_names_the_output(tmp_path):
    """A full disk gave "[Errno 28] No space left on device" without the output's name."""
    import errno

    from brdfkit.errors import OutputError
    from brdfkit.io import atomic_write

    def full(path):
        raise OSError(errno.ENOSPC, "No space left on device")

    with pytest.raises(OutputError, match=r"result\.exr.*No space left on device"):
        atomic_write(tmp_path / "result.exr", full)
    assert list(tmp_path.iterdir()) == []
