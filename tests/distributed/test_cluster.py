"""brdfkit's local workers keep glibc's adaptive mmap threshold (no MALLOC_TRIM_THRESHOLD_ from
Dask), unless the user exports one."""

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
