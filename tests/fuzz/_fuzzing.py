"""The fuzzing harness shared by the tests in this folder and ``benchmarks/fuzz.py``.

Each fuzz test draws inputs with hypothesis (byte-level mutations of real files for the readers,
random text for the spec parsers) and hands them to a reader through :func:`run_case`, which
lets through only the documented error types (:class:`brdfkit.errors.BrdfkitError`) and counts
every case by outcome. Anything else escaping the reader fails the test, and so does a case that
runs longer than :data:`HANG_SECONDS` (a hang).

In the test suite each target runs a small, derandomised number of cases (``ci_cases``);
``BRDFKIT_FUZZ_CASES=N`` (set by ``benchmarks/fuzz.py``) runs N random cases per target instead.
"""

from __future__ import annotations

import collections
import os
import signal
from collections.abc import Callable, Sequence
from typing import Any

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

from brdfkit.errors import BrdfkitError

CASES = int(os.environ.get("BRDFKIT_FUZZ_CASES", "0"))
"""Cases per target on demand (0: the test suite's small fixed number)."""

HANG_SECONDS = float(os.environ.get("BRDFKIT_FUZZ_HANG_SECONDS", "30"))
"""A case running longer than this counts as a hang."""

OUTCOMES: dict[str, collections.Counter[str]] = collections.defaultdict(collections.Counter)
"""Per target: how many cases ended how ("ok" or the documented error's type name)."""


class Hang(BaseException):
    """A case ran past :data:`HANG_SECONDS` (a ``BaseException``, so that no reader's
    ``except Exception`` can swallow it)."""


def fuzz_settings(ci_cases: int) -> settings:
    """hypothesis settings for a target: ``ci_cases`` derandomised cases in the test suite, or
    ``BRDFKIT_FUZZ_CASES`` random ones on demand."""
    return settings(
        max_examples=CASES or ci_cases,
        derandomize=not CASES,
        deadline=None,
        database=None,
        suppress_health_check=list(HealthCheck),
    )


def _alarm(signum: int, frame: Any) -> None:
    raise Hang(f"a case ran longer than {HANG_SECONDS:g} s")


def run_case(target: str, function: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """``function(*args, **kwargs)`` under the hang alarm; a documented error is counted and
    returns ``None``, anything else propagates (and fails the test)."""
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, HANG_SECONDS)
    try:
        result = function(*args, **kwargs)
    except BrdfkitError as error:
        OUTCOMES[target][type(error).__name__] += 1
        return None
    except Hang:
        OUTCOMES[target]["hang"] += 1
        raise
    except BaseException as error:
        OUTCOMES[target][f"UNDOCUMENTED {type(error).__name__}"] += 1
        raise
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    OUTCOMES[target]["ok"] += 1
    return result


_INTERESTING_BYTES = (0x00, 0x01, 0x7F, 0x80, 0xFE, 0xFF)
_INTERESTING_TOKENS = (
    "nan", "inf", "-inf", "-1", "0", "-0", "1e308", "1e-320", "1e999", "99999999999", "", "x",
)  # fmt: skip


@st.composite
def mutated(draw: st.DrawFn, seeds: Sequence[bytes], text: bool = False) -> bytes:
    """A real file's bytes with 1–4 random mutations: bit flips, interesting bytes, truncation,
    deletion, insertion and duplication of slices, and (``text=True``) a whitespace-separated
    token replaced by a number or word that readers of text formats must handle."""
    data = bytearray(draw(st.sampled_from(list(seeds))))
    for _ in range(draw(st.integers(1, 4))):
        size = len(data)
        where = draw(st.integers(0, max(size - 1, 0)))
        choices = ["flip", "byte", "truncate", "delete", "insert", "duplicate"]
        if text:
            choices += ["token", "token"]
        kind = draw(st.sampled_from(choices))
        if kind == "flip" and size:
            data[where] ^= 1 << draw(st.integers(0, 7))
        elif kind == "byte" and size:
            data[where] = draw(st.sampled_from(_INTERESTING_BYTES))
        elif kind == "truncate":
            del data[where:]
        elif kind == "delete":
            del data[where : where + draw(st.integers(1, 64))]
        elif kind == "insert":
            data[where:where] = draw(st.binary(min_size=1, max_size=16))
        elif kind == "duplicate":
            data[where:where] = data[where : where + draw(st.integers(1, 256))]
        elif kind == "token":
            data = bytearray(_replace_token(bytes(data), where, draw(st.sampled_from(
                _INTERESTING_TOKENS))))  # fmt: skip
    return bytes(data)


def _replace_token(data: bytes, near: int, token: str) -> bytes:
    """``data`` with the whitespace-separated token at or after byte ``near`` replaced."""
    start = near
    while start < len(data) and data[start : start + 1].isspace():
        start += 1
    while start > 0 and not data[start - 1 : start].isspace():
        start -= 1
    end = start
    while end < len(data) and not data[end : end + 1].isspace():
        end += 1
    return data[:start] + token.encode() + data[end:]
