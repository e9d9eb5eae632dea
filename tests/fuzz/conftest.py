"""Fuzz tests: write the per-target outcome counts for ``benchmarks/fuzz.py``."""

from __future__ import annotations

import json
import os

from _fuzzing import OUTCOMES


def pytest_sessionfinish(session, exitstatus) -> None:
    report = os.environ.get("BRDFKIT_FUZZ_REPORT")
    if report:
        with open(report, "w") as stream:
            json.dump({t: dict(c) for t, c in sorted(OUTCOMES.items())}, stream, indent=2)
