"""The command line and the explorer under faults: hostile inputs and interrupts, at full size.

- **Interrupts**: ``brdfkit atlas``, and ``brdfkit fit`` of 8 tables × 3 models on a local
  Dask cluster of 2 workers, are started in a session of their own through the console script
  pip writes for ``[project.scripts]``, and once their workers have run a second (or, for the
  Dask batch, as soon as its first worker process exists: the workers are still importing),
  SIGINT goes twice to the whole group, 0.4 s apart (two Ctrl-C at a terminal): seconds from
  the first to the exit, the exit status, the stderr lines, the processes of the session left
  a second later and the temporaries left in the output folder.
- **A Ctrl-C while starting**: ``brdfkit atlas --help`` through the console script gets SIGINT
  10, 30, 60, 100 and 200 ms after it was started, ``--starts`` times each: how it ended
  (brdfkit's ``interrupted`` line and 130, finished, killed before the interpreter had a
  handler, or Python's traceback); beside it the median time the interpreter takes to start
  (``python -c pass``) and to reach brdfkit's guard (``python -c "import re, brdfkit"``: pip's
  script imports ``re``, then brdfkit, whose ``brdfkit.cli`` guards first).
- **A PNG bomb**: a valid 20000 × 20000 RGB PNG (1.2 MB) given to ``brdfkit hdr``: the exit
  status, the error line and the command's peak resident memory (``wait4``'s ``ru_maxrss``).
- **Degenerate inputs**: ``hdr -t 1,1,1`` on three different exposures, and ``fit`` of a
  MERL-layout file with one entry of 1e308: exit status and error line.
- **The explorer**: a server in a process of its own gets one render of 8 entries of 2000
  channels at 512 px on a WebSocket, then an ordinary render, then a model tree holding a
  400-digit integer, then an ordinary render: each answer's type, and the server's peak
  resident memory (``VmHWM``) before and after.
- **The protocol fuzzed**: ``tests/fuzz/test_fuzz_explore.py`` with ``--messages`` cases
  (mutated render messages, each sent on one connection and waited for): the replies by type,
  and the test's verdict (it fails on a message left unanswered or a worker logged dead).

Run ``python benchmarks/bench_faults.py`` (a few minutes; needs the ``explore``, ``dask`` and
``test`` extras); results go to ``benchmarks/results/faults.json``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import signal
import struct
import subprocess
import sys
import tempfile
import time
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from _machine import write_results

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT / "src")}


def console_script(folder: Path) -> list[str]:
    """``brdfkit`` from this tree: the script pip writes for ``[project.scripts]`` (its
    template), in ``folder``, run by this interpreter."""
    import tomllib

    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    module, function = pyproject["project"]["scripts"]["brdfkit"].split(":")
    script = folder / "brdfkit"
    script.write_text(
        f"#!{sys.executable}\nimport re\nimport sys\nfrom {module} import {function}\n"
        "if __name__ == '__main__':\n"
        "    sys.argv[0] = re.sub(r'(-script\\.pyw|\\.exe)?$', '', sys.argv[0])\n"
        f"    sys.exit({function}())\n"
    )
    return [sys.executable, str(script)]


BRDFKIT: list[str] = []
"""``brdfkit`` (:func:`console_script`), set by :func:`main`."""


def _session_processes(session: int) -> int:
    count = 0
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                status = (entry / "stat").read_text()
                fields = status.rsplit(")", 1)[1].split()
                if int(fields[3]) == session and fields[0] != "Z":
                    count += 1
            except (OSError, IndexError, ValueError):
                continue
    return count


def _children(pid: int) -> int:
    """The child processes of ``pid``, started from any of its threads."""
    count = 0
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            count += len((task / "children").read_text().split())
        except OSError:
            continue
    return count


def _merl_files(folder: Path, count: int) -> list[str]:
    """MERL-layout tables of random values (the fits' inputs)."""
    rng = np.random.default_rng(0)
    paths = []
    for k in range(count):
        values = rng.uniform(0.001, 0.05, 3 * 90 * 90 * 180)
        paths.append(str(folder / f"table{k}.binary"))
        header = np.asarray((90, 90, 180), "<i4").tobytes()
        Path(paths[-1]).write_bytes(header + values.astype("<f8").tobytes())
    return paths


def interrupts(folder: Path, repeats: int) -> list[dict[str, Any]]:
    """Two Ctrl-C on the atlas and on a Dask batch fit, ``repeats`` times each."""
    tables = _merl_files(folder, 8)
    models = ["-m", "ggx", "-m", "beckmann", "-m", "ward"]
    commands = {
        "atlas": (["atlas", "-r", "32", "-s", "4", "-o"], 1.0),
        "fit batch (Dask)": (["fit", *tables, *models, "--workers", "2", "-o"], 1.0),
        "fit batch (Dask), workers starting": (
            ["fit", *tables, *models, "--workers", "2", "-o"],
            0.0,
        ),
    }
    records = []
    for (label, (args, busy)), k in itertools.product(commands.items(), range(repeats)):
        out = str(folder / f"out{k}{label.replace(' ', '')[:12]}")
        records.append({"command": label, **_interrupted([*args, out], busy)})
    return records


def temporaries(folder: Path) -> list[Path]:
    """brdfkit's temporary files under ``folder`` (its manifests are no temporaries)."""
    return [p for p in folder.rglob(".brdfkit-*") if p.name != ".brdfkit-outputs.json"]


def _interrupted(args: list[str], busy: float) -> dict[str, Any]:
    """Start ``brdfkit ARGS`` in a session of its own; once its workers have run ``busy``
    seconds, SIGINT to the group twice, 0.4 s apart."""
    out = Path(args[-1])
    process = subprocess.Popen(
        [*BRDFKIT, *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        start_new_session=True, env=ENV,
    )  # fmt: skip
    while _children(process.pid) == 0 and process.poll() is None:
        time.sleep(0.05)
    time.sleep(busy)
    start = time.perf_counter()
    os.killpg(process.pid, signal.SIGINT)
    time.sleep(0.4)
    try:
        os.killpg(process.pid, signal.SIGINT)
    except ProcessLookupError:
        pass
    try:
        _, stderr = process.communicate(timeout=30)
        seconds = time.perf_counter() - start
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        _, stderr = process.communicate()
        seconds = None
    time.sleep(1.0)
    return {
        "seconds": seconds, "status": process.returncode, "stderr": stderr.splitlines(),
        "processes_left": _session_processes(process.pid),
        "temporaries_left": len(temporaries(out)),
    }  # fmt: skip


def _median_seconds(command: list[str], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        subprocess.run(command, env=ENV, check=True)
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def _start_outcome(delay: float) -> str:
    process = subprocess.Popen(
        [*BRDFKIT, "atlas", "--help"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        text=True, env=ENV,
    )  # fmt: skip
    time.sleep(delay)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    if "Traceback" in stderr or "Fatal Python error" in stderr:
        return "Python's traceback"
    if process.returncode == 130 and stderr == "error: interrupted\n":
        return "interrupted, 130"
    if process.returncode == 0 and not stderr:
        return "finished, 0"
    if process.returncode == -signal.SIGINT and not stderr:
        return "killed before the interpreter's handler"
    return f"status {process.returncode}: {stderr.strip()}"


def start(starts: int) -> dict[str, Any]:
    """A SIGINT 10–200 ms into ``brdfkit atlas --help``, ``starts`` times per delay."""
    outcomes = {}
    for delay in (0.01, 0.03, 0.06, 0.1, 0.2):
        counts: dict[str, int] = {}
        for _ in range(starts):
            outcome = _start_outcome(delay)
            counts[outcome] = counts.get(outcome, 0) + 1
        outcomes[f"{delay * 1000:.0f}"] = counts
    return {
        "starts": starts,
        "outcomes_by_ms": outcomes,
        "interpreter_ms": round(1000 * _median_seconds([sys.executable, "-c", "pass"], 9), 1),
        "to_guard_ms": round(
            1000 * _median_seconds([sys.executable, "-c", "import re, brdfkit"], 9), 1
        ),
    }


def _png(width: int, height: int) -> bytes:
    def chunk(kind: bytes, data: bytes) -> bytes:
        return (
            struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
        )

    row = b"\0" * (1 + 3 * width)
    compressor = zlib.compressobj(9)
    body = b"".join(compressor.compress(row) for _ in range(height)) + compressor.flush()
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", body) + chunk(b"IEND", b"")
    )


def _run(args: list[str]) -> dict[str, Any]:
    """A command's exit status, stderr lines and peak resident memory (MiB)."""
    process = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=ENV)
    stderr = process.stderr.read().decode()
    _, status, usage = os.wait4(process.pid, 0)
    process.returncode = os.waitstatus_to_exitcode(status)
    return {"status": process.returncode, "stderr": stderr.splitlines(),
            "peak_mib": round(usage.ru_maxrss / 1024, 1)}  # fmt: skip


def _exposures(folder: Path) -> list[str]:
    from brdfkit.io import write_image

    base = np.random.default_rng(0).uniform(0.05, 0.3, (32, 32, 3))
    paths = []
    for k, t in enumerate((1, 2, 4)):
        paths.append(str(folder / f"exposure{k}.png"))
        write_image(paths[-1], np.clip(base * t, 0, 1), srgb=False)
    return paths


def bomb_and_degenerate(folder: Path) -> dict[str, Any]:
    exposures = _exposures(folder)
    bomb = folder / "bomb.png"
    bomb.write_bytes(_png(20_000, 20_000))
    merl = folder / "huge-entry.binary"
    values = np.full(3 * 90 * 90 * 180, 0.01)
    values[12345] = 1e308
    merl.write_bytes(np.asarray((90, 90, 180), "<i4").tobytes() + values.astype("<f8").tobytes())
    return {
        "png_bomb_bytes": bomb.stat().st_size,
        "png_bomb": _run(
            [
                *BRDFKIT,
                "hdr",
                *exposures[:2],
                str(bomb),
                "-t",
                "1,2,4",
                "-o",
                str(folder / "bomb.exr"),
            ]
        ),
        "equal_times": _run(
            [*BRDFKIT, "hdr", *exposures, "-t", "1,1,1", "-o", str(folder / "equal.exr")]
        ),
        "merl_1e308": _run([*BRDFKIT, "fit", str(merl), "-m", "ggx", "--json"]),
    }


SERVER = """
import sys
from brdfkit.explore.server import ExplorerServer
from brdfkit.explore.session import Session
server = ExplorerServer(Session(), []).start()
print(server.port, server.token, flush=True)
sys.stdin.read()
server.stop()
"""


def _high_water(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return round(int(line.split()[1]) / 1024, 1)
    return float("nan")


def _answer(ws: Any) -> dict[str, Any]:
    """The frame or error that answers the message just sent (albedo replies skipped)."""
    from brdfkit.explore.protocol import decode_frame

    while True:
        header = decode_frame(ws.recv(timeout=120))[0]
        if header["type"] in ("frame", "error"):
            return header


def explorer() -> dict[str, Any]:
    from websockets.sync.client import connect

    from brdfkit.explore.protocol import decode_frame

    server = subprocess.Popen([sys.executable, "-c", SERVER], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True, env=ENV)  # fmt: skip
    port, token = server.stdout.readline().split()
    wide = "ggx(alpha=[" + ", ".join(["0.1"] * 2000) + "])"
    plain = [{"id": "p", "source": {"spec": "lambertian + ggx(alpha=0.2)"}}]
    huge = {"tree": {"model": "ggx", "params": {"alpha": "HUGE"}}}
    wides = [{"id": f"w{k}", "source": {"spec": wide}} for k in range(8)]
    steps = [
        ("8 × 2000 channels at 512 px", wides, 512),
        ("an ordinary render", plain, 512),
        ("a 400-digit integer in a tree", [{"id": "h", "source": huge}], 64),
        ("an ordinary render", plain, 64),
    ]  # fmt: skip
    record: dict[str, Any] = {"steps": []}
    try:
        with connect(f"ws://127.0.0.1:{port}/{token}/ws", origin=f"http://127.0.0.1:{port}",
                     max_size=2**28, open_timeout=60) as ws:  # fmt: skip
            ws.send(json.dumps({"type": "render", "seq": 1, "state": {"entries": plain}}))
            decode_frame(ws.recv(timeout=120))
            record["peak_mib_before"] = _high_water(server.pid)
            for seq, (label, entries, resolution) in enumerate(steps, start=2):
                text = json.dumps({"type": "render", "seq": seq, "state": {
                    "entries": entries, "view": {"resolution": resolution}}})  # fmt: skip
                start = time.perf_counter()
                ws.send(text.replace('"HUGE"', "1" + "0" * 400))
                header = _answer(ws)
                record["steps"].append({
                    "message": label,
                    "answer": header["type"],
                    "entry_errors": sum("error" in e for e in header.get("entries", [])),
                    "seconds": round(time.perf_counter() - start, 2),
                })  # fmt: skip
            record["peak_mib_after"] = _high_water(server.pid)
    finally:
        server.stdin.close()
        start = time.perf_counter()
        try:
            server.wait(timeout=120)
        except subprocess.TimeoutExpired:  # on a loaded machine; the record says so
            server.kill()
            server.wait()
        record["server_stop_seconds"] = round(time.perf_counter() - start, 1)
    return record


def protocol_fuzz(messages: int, folder: Path) -> dict[str, Any]:
    report = folder / "fuzz.json"
    env = {**ENV, "BRDFKIT_FUZZ_CASES": str(messages), "BRDFKIT_FUZZ_REPORT": str(report)}
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
         "tests/fuzz/test_fuzz_explore.py"],
        cwd=ROOT, env=env, stdout=sys.stderr, check=False,
    )  # fmt: skip
    outcomes = json.loads(report.read_text()).get("explore protocol", {}) if report.exists() else {}
    return {"messages": messages, "passed": done.returncode == 0, "replies": outcomes,
            "seconds": round(time.perf_counter() - start, 1)}  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--messages", type=int, default=10_000, help="fuzzed protocol messages")
    parser.add_argument("--repeats", type=int, default=3, help="interrupted runs per command")
    parser.add_argument("--starts", type=int, default=10, help="interrupted starts per delay")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        BRDFKIT[:] = console_script(folder)
        records = {
            "interrupts": interrupts(folder, args.repeats),
            "start": start(args.starts),
            **bomb_and_degenerate(folder),
            "explorer": explorer(),
            "protocol_fuzz": protocol_fuzz(args.messages, folder),
        }
    path = write_results(__file__, records, packages=("numpy", "uvicorn", "websockets"))
    print(json.dumps(records, indent=1))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
