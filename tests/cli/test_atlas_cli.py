"""``brdfkit atlas`` on a terminal keeps the process single-threaded, so its cards fork."""

from __future__ import annotations

import io
import threading

from rich.console import Console
from typer.testing import CliRunner

from brdfkit.cli import app

runner = CliRunner()


def test_the_progress_bar_on_a_terminal_starts_no_thread(tmp_path, monkeypatch):
    """``report._build_cards`` forks its workers only from a single-threaded process (otherwise
    it builds every card in turn), and rich's auto-refresh thread would make it two-threaded.
    The bar is shown (a terminal) and redrawn as cards finish, from the one thread."""
    import brdfkit.cli.atlas as atlas_cli
    import brdfkit.report.atlas as report

    screen = io.StringIO()
    monkeypatch.setattr(atlas_cli, "status", Console(file=screen, force_terminal=True))
    seen = {}

    def build_atlas(page, *args, progress=None, **kwargs):
        seen["threads"] = threading.active_count()
        progress("lambertian", 1, 2)
        page.write_text("<html></html>", encoding="utf-8")
        return page

    monkeypatch.setattr(report, "build_atlas", build_atlas)
    before = threading.active_count()
    result = runner.invoke(app, ["atlas", "-o", str(tmp_path / "atlas")])
    assert result.exit_code == 0, result.output
    assert seen["threads"] == before
    assert "atlas: lambertian" in screen.getvalue()  # the bar was drawn on the "terminal"
