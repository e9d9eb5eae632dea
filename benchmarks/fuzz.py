"""Fuzz every reader and the spec parsers at length: the test suite's fuzz tests, many more cases.

    python benchmarks/fuzz.py                       # 10,000 cases per test, 20,000 specs
    python benchmarks/fuzz.py --cases 500 --spec-cases 1000   # a quick look

Runs ``tests/fuzz`` twice under pytest (the readers, then the spec and light parsers) with
``BRDFKIT_FUZZ_CASES`` set, and prints, per target, how many cases ended in each outcome: ``ok``
(the input was read and checked), a documented error type (``FormatError``, ``ImageReadError``,
``ParameterError``, …), or a failure (an undocumented exception or a hang, which also fails the
run). Exits non-zero when any test failed.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SPEC_TESTS = "tests/fuzz/test_fuzz_spec.py"


def _run(tests: list[str], cases: int, report: Path) -> tuple[int, float]:
    environment = {
        **os.environ,
        "BRDFKIT_FUZZ_CASES": str(cases),
        "BRDFKIT_FUZZ_REPORT": str(report),
    }
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *tests],
        cwd=ROOT,
        env=environment,
        stdout=sys.stderr,  # pytest's report; standard output holds only this script's table
        check=False,
    )
    return done.returncode, time.perf_counter() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=10_000, help="cases per reader test")
    parser.add_argument("--spec-cases", type=int, default=20_000, help="cases per spec test")
    parser.add_argument("--json", action="store_true", help="print the counts as JSON")
    args = parser.parse_args()
    readers = sorted(
        str(p.relative_to(ROOT)) for p in (ROOT / "tests" / "fuzz").glob("test_fuzz_*.py")
    )
    readers = [t for t in readers if t != SPEC_TESTS]
    outcomes: dict[str, dict[str, int]] = {}
    failed = False
    seconds = {}
    with tempfile.TemporaryDirectory() as folder:
        for name, tests, cases in (
            ("readers", readers, args.cases),
            ("specs", [SPEC_TESTS], args.spec_cases),
        ):
            report = Path(folder) / f"{name}.json"
            code, seconds[name] = _run(tests, cases, report)
            failed |= code != 0
            if report.exists():
                outcomes.update(json.loads(report.read_text()))
    if args.json:
        print(json.dumps({"outcomes": outcomes, "seconds": seconds, "failed": failed}, indent=2))
    else:
        print(f"\n{'target':<14}{'cases':>9}  outcomes")
        for target, counts in sorted(outcomes.items()):
            total = sum(counts.values())
            listed = ", ".join(f"{k} {v}" for k, v in sorted(counts.items(), key=lambda i: -i[1]))
            print(f"{target:<14}{total:>9}  {listed}")
        timing = ", ".join(f"{k} {v:.0f} s" for k, v in seconds.items())
        print(f"\nwall time: {timing}; {'FAILED' if failed else 'no failures, no hangs'}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
