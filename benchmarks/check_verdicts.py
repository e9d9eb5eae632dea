"""Every physics check's verdict on each default atlas card's model, and its CPU seconds.

``python benchmarks/check_verdicts.py OUT.json`` writes, per card, the
:func:`brdfkit.checks.properties. check` results of the model the atlas checks (the card's middle
instance) to ``OUT.json`` (atomically; diff two runs to see that a change keeps every verdict,
value and detail), and prints the CPU seconds of each check per card and in total.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from brdfkit.checks import properties
from brdfkit.io import atomic_write
from brdfkit.report.atlas import default_cards


class _Laps:
    """CPU seconds between ``properties.check``'s progress calls, per check name."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self._name: str | None = None
        self._start = time.process_time()

    def __call__(self, name: str | None) -> None:
        now = time.process_time()
        if self._name is not None:
            self.seconds[self._name] = now - self._start
        self._name, self._start = name, now


def main() -> None:
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1, user_api="blas"):  # as the atlas's processes
        _verdicts()


def _verdicts() -> None:
    out: dict[str, list] = {}
    totals: dict[str, float] = {}
    for title, models in default_cards():
        laps = _Laps()
        report = properties.check(models[len(models) // 2], progress=laps)
        laps(None)
        for name, seconds in laps.seconds.items():
            totals[name] = totals.get(name, 0.0) + seconds
        out[title] = [r.to_dict() for r in report.results]
        print(f"{title:24s} " + ", ".join(f"{k} {v:.2f}" for k, v in laps.seconds.items()))
    print("CPU s per check: " + ", ".join(f"{k} {v:.2f}" for k, v in totals.items())
          + f"; total {sum(totals.values()):.2f}")  # fmt: skip
    text = json.dumps(out, indent=1, ensure_ascii=False)
    atomic_write(Path(sys.argv[1]), lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


if __name__ == "__main__":
    main()
