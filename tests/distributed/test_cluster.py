"""brdfkit's local workers keep glibc's adaptive mmap threshold (no MALLOC_TRIM_THRESHOLD_ from
Dask), unless the user exports one; with ``keep_memory`` they keep freed memory."""

from __future__ import annotations

import os

import pytest

pytest.importorskip("distributed", reason="needs the dask extra: pip install 'brdfkit[dask]'")

from brdfkit.distributed.cluster import client


def _trim_threshold() -> str | None:
    return os.environ.get("MALLOC_TRIM_THRESHOLD_")


@pytest.mark.slow
def test_local_workers_do_not_get_dasks_malloc_trim_threshold(monkeypatch):
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    with client(workers=1) as local:
        assert list(local.run(_trim_threshold).values()) == [None]
    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", "131072")  # the user's own choice still holds
    with client(workers=1) as local:
        assert list(local.run(_trim_threshold).values()) == ["131072"]


def _malloc_settings() -> tuple[str | None, str | None]:
    return os.environ.get("MALLOC_MMAP_THRESHOLD_"), os.environ.get("MALLOC_TRIM_THRESHOLD_")


@pytest.mark.slow
def test_keep_memory_workers_get_high_malloc_thresholds_unless_the_user_exports_them(
    monkeypatch,
):
    monkeypatch.delenv("MALLOC_MMAP_THRESHOLD_", raising=False)
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    with client(workers=1, keep_memory=True) as local:
        assert list(local.run(_malloc_settings).values()) == [(str(2**30), str(2**32))]
    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", "131072")
    with client(workers=1, keep_memory=True) as local:
        assert list(local.run(_malloc_settings).values()) == [(str(2**30), "131072")]
