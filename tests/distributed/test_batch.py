"""Batch fitting on a real LocalCluster of two worker processes: the results equal the
single-process fits, a re-run skips them, a worker killed mid-batch loses no result and
duplicates none."""

from __future__ import annotations

import json
import os
import signal
import time

import pytest
from typer.testing import CliRunner

pytest.importorskip("distributed", reason="needs the dask extra: pip install 'brdfkit[dask]'")

from brdfkit.brdf import parse
from brdfkit.cli import app
from brdfkit.distributed import batch
from brdfkit.fit.analytic import fit
from brdfkit.measured.merl import read_merl, write_merl

runner = CliRunner()
MODELS = ("lambertian", "lambertian + ggx")
OPTIONS = {"objective": "cube_root", "loss": "soft_l1", "loss_scale": 0.5, "mode": "shared",
           "starts": 1, "fixed": [], "seed": 0}  # fmt: skip
DETERMINED = ("spec", "params", "cost", "nfev", "samples", "fit_samples", "success")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("measured")
    specs = {"grey": "lambertian(rho=0.4) + ggx(alpha=0.2)",
             "red": "lambertian(rho=[0.5, 0.3, 0.2]) + ggx(alpha=0.35)"}  # fmt: skip
    paths = []
    for name, spec in specs.items():
        paths.append(folder / f"{name}.binary")
        write_merl(paths[-1], parse(spec))
    return paths


@pytest.mark.slow
def test_batch_on_two_workers_equals_single_process_fits_and_reruns_skip(files, tmp_path):
    out = tmp_path / "fits"
    args = ["fit", *map(str, files), *[a for m in MODELS for a in ("-m", m)], "--starts", "1"]
    first = runner.invoke(app, [*args, "--workers", "2", "-o", str(out)])
    assert first.exit_code == 0, first.output
    lines = (out / "results.jsonl").read_text().splitlines()
    records = {(r["file"], r["model"]): r for r in map(json.loads, lines)}
    assert len(lines) == len(records) == 4
    for file in files:
        measured = read_merl(file)
        for model in MODELS:
            record = records[(str(file), model)]
            alone = fit(measured, model, **{k: v for k, v in OPTIONS.items()}).to_dict()
            assert {k: record[k] for k in DETERMINED} == {k: alone[k] for k in DETERMINED}
            # Norms over 10⁶ samples: BLAS sums in another order with one thread per worker.
            assert record["errors"] == pytest.approx(alone["errors"], rel=1e-12, abs=1e-300)
            task = batch.FitTask(str(file), batch.file_sha256(file), model, OPTIONS)
            assert record["key"] == task.key
            saved = json.loads((out / task.folder / "fit.json").read_text())
            assert saved == record
    header = (out / "results.csv").read_text().splitlines()[0].split(",")
    assert header[:4] == ["key", "file", "model", "status"] and "param.1.ggx.alpha" in header
    before = {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file()}
    again = runner.invoke(app, [*args, "--workers", "2", "-o", str(out)])
    assert again.exit_code == 0, again.output
    assert "4 of 4 fits are done" in again.output
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file()} == before
    one = ["fit", str(files[0]), "-m", MODELS[0], "--starts", "1", "--workers", "1"]
    changed = runner.invoke(app, [*one, "--seed", "1", "-o", str(out)])  # another option: new
    assert changed.exit_code == 0 and "1 fits (0 done before)" in changed.output
    assert len((out / "results.jsonl").read_text().splitlines()) == 5  # earlier rows kept


@pytest.mark.slow
def test_a_worker_killed_mid_batch_still_yields_every_result_once(files):
    from distributed import Client, LocalCluster

    planned = batch.tasks(files * 2, MODELS[:1], **OPTIONS)
    planned = [
        batch.FitTask(t.file, t.file_sha256, t.model, {**t.options, "seed": seed})
        for seed, t in enumerate(planned)
    ]  # 4 distinct fits of ~1 s
    results: list[tuple[str, dict]] = []
    killed: list[int] = []
    with (
        LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=50,
        ) as cluster,  # fmt: skip
        Client(cluster) as client,
    ):
        pids = client.run(os.getpid)

        def on_result(task, record):
            results.append((task.key, record))
            if not killed:  # one fit done: kill a worker that is running another, right now
                deadline = time.monotonic() + 10
                while time.monotonic() < deadline:
                    busy = [w for w, keys in client.processing().items() if keys]
                    if busy:
                        killed.append(pids[busy[0]])
                        os.kill(pids[busy[0]], signal.SIGKILL)
                        return
                    time.sleep(0.01)

        batch.run(client, planned, on_result)
        survivors = set(client.run(os.getpid).values())
    assert killed and killed[0] not in survivors  # the nanny started a new worker process
    keys = [key for key, _ in results]
    assert sorted(keys) == sorted(t.key for t in planned)  # every fit, exactly once
    assert all(record["status"] == "ok" for _, record in results)


@pytest.mark.slow
def test_a_batch_prepares_each_file_once_for_all_its_models(files, monkeypatch):
    import brdfkit.measured as measured_io
    from distributed import Client, LocalCluster

    reads: list[str] = []

    def counted(path, *args, **kwargs):
        reads.append(str(path))
        return read_merl(path, *args, **kwargs)

    monkeypatch.setattr(measured_io, "read_merl", counted)  # workers are threads here
    planned = batch.tasks(files, MODELS, **OPTIONS)
    records = {}
    with (
        LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=False,
            dashboard_address=None,
            silence_logs=50,
        ) as cluster,
        Client(cluster) as client,
    ):
        batch.run(client, planned, lambda task, record: records.setdefault(task.key, record))
    assert sorted(reads) == sorted(map(str, files))  # once per file, not once per fit
    for task in planned:
        alone = fit(read_merl(task.file), task.model, **OPTIONS).to_dict()
        record = records[task.key]
        assert {k: record[k] for k in DETERMINED} == {k: alone[k] for k in DETERMINED}
        assert record["errors"] == pytest.approx(alone["errors"], rel=1e-12, abs=1e-300)


def test_a_changed_file_or_a_bad_seed_is_reported_by_each_fit(files, tmp_path):
    copy = tmp_path / "copy.binary"
    copy.write_bytes(files[0].read_bytes())
    (task,) = batch.tasks([copy], MODELS[:1], **OPTIONS)
    copy.write_bytes(files[1].read_bytes())
    message = f"{copy}: changed since the batch was planned"
    assert batch.prepare(task) == message
    for model in MODELS:
        other = batch.FitTask(task.file, task.file_sha256, model, OPTIONS)
        record = batch.fit_prepared(other, message)
        assert (record["status"], record["message"], record["key"]) == ("error", message, other.key)
    (replanned,) = batch.tasks([copy], MODELS[:1], **OPTIONS)
    record = batch.fit_one(replanned)
    assert record["params"] == fit(read_merl(files[1]), MODELS[0], **OPTIONS).params
    bad = batch.FitTask(task.file, replanned.file_sha256, task.model, {**OPTIONS, "seed": "0"})
    record = batch.fit_one(bad)
    assert record["status"] == "error"
    assert record["message"] == f"seed must be an integer in [0, {2**63 - 1}]; got '0'"
