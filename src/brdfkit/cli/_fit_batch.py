"""``brdfkit fit`` on many files × models: one Dask task per fit, a results table, a re-run
that skips what is done (see :mod:`brdfkit.distributed.batch`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import typer

from brdfkit.cli._app import console, fail, progress, shown, status
from brdfkit.cli._output import OutputFolder

RESULTS = ("results.jsonl", "results.csv")
"""The batch's table, in the output folder."""


def run_batch(
    files: list[Path],
    models: list[str],
    options: dict[str, Any],
    output: Path | None,
    workers: int | None,
    scheduler: str | None,
    as_json: bool,
) -> None:
    """Fit every file × model on a Dask cluster; write ``results.jsonl``, ``results.csv`` and
    ``<file>-<key>/fit.json`` per fit in ``output``; print a summary table (or JSON)."""
    from brdfkit.brdf import parse
    from brdfkit.distributed import batch, cluster

    cluster.require_dask()
    for model in models:  # a spec that does not read is refused before any work
        parse(model)
    if output is None:
        fail("a batch (several files or models, --workers or --scheduler) needs -o FOLDER")
    folder = OutputFolder(output, RESULTS, inputs=files)
    planned = list({t.key: t for t in batch.tasks(files, models, **options)}.values())
    records = _previous(output)
    todo = [t for t in planned if not _done(output, t, records)]
    skipped = len(planned) - len(todo)
    if skipped:
        status.print(f"{skipped} of {len(planned)} fits are done in {shown(output)}; skipping them")
    fits = {t.key: OutputFolder(output / t.folder, ("fit.json",), inputs=files) for t in todo}
    if todo:
        with (
            cluster.client(workers, scheduler, keep_memory=True) as dask_client,
            progress() as bar,
        ):
            task = bar.add_task(f"fitting on {_workers(dask_client)} workers", total=len(todo))

            def record(fit_task: batch.FitTask, result: dict[str, Any]) -> None:
                text = json.dumps(result, indent=2, ensure_ascii=False, allow_nan=False) + "\n"
                if result["status"] == "ok":
                    fits[fit_task.key].write("fit.json", lambda p: p.write_text(text, "utf-8"))
                records[fit_task.key] = result
                _write_table(folder, records)
                bar.update(
                    task, advance=1, description=f"{Path(fit_task.file).name} × {fit_task.model}"
                )

            batch.run(dask_client, todo, record)
    ours = [records[t.key] for t in planned]
    failed = [r for r in ours if r["status"] != "ok"]
    for r in failed:
        status.print(f"error: {shown(r['file'])} × {r['model']!r}: {r.get('message', '')}")
    if as_json:
        typer.echo(json.dumps({"output": shown(output), "fits": ours}, indent=2, allow_nan=False))
    else:
        _print_table(ours)
        console.print(
            f"{len(ours) - len(failed)} fits ({skipped} done before); wrote {shown(output)}/"
        )
    if failed:
        raise typer.Exit(2)


def _workers(dask_client: Any) -> int:
    return len(dask_client.scheduler_info(n_workers=-1).get("workers", {}))


def _previous(output: Path) -> dict[str, dict[str, Any]]:
    """The records of an earlier run in ``output`` (none when it has no table)."""
    from brdfkit.distributed.batch import read_records

    try:
        return read_records((output / "results.jsonl").read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError):
        return {}


def _done(output: Path, fit_task: Any, records: dict[str, dict[str, Any]]) -> bool:
    """Whether an earlier run finished this fit: an ``ok`` record and its fit.json, intact."""
    record = records.get(fit_task.key)
    if record is None or record.get("status") != "ok":
        return False
    try:
        saved = json.loads((output / fit_task.folder / "fit.json").read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError):
        return False
    return saved == record


def _write_table(folder: OutputFolder, records: dict[str, dict[str, Any]]) -> None:
    from brdfkit.distributed.batch import jsonl, table

    ordered = sorted(records.values(), key=lambda r: (r["file"], r["model"], r["key"]))
    lines, rows = jsonl(ordered), table(ordered)
    folder.write("results.jsonl", lambda p: p.write_text(lines, encoding="utf-8"))
    folder.write("results.csv", lambda p: p.write_text(rows, encoding="utf-8"))


def _print_table(records: list[dict[str, Any]]) -> None:
    from rich.table import Table

    view = Table(title=f"{len(records)} fits")
    for column in ("file", "model", "cube_root_rmse", "cosine_rmse", "seconds"):
        view.add_column(column, justify="left" if column in ("file", "model") else "right")
    for r in records:
        errors = r.get("errors", {})
        cells = [f"{errors[name]:.4g}" if name in errors else "-" for name in
                 ("cube_root_rmse", "cosine_rmse")]  # fmt: skip
        seconds = f"{r['seconds']:.1f}" if "seconds" in r else r["status"]
        view.add_row(Path(r["file"]).name, r["model"], *cells, seconds)
    console.print(view)
