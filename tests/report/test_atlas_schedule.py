"""The atlas hands its cards to the workers heaviest first (longest processing time first),
with the options (the map) given to each worker once."""

from __future__ import annotations

import functools
import os
import threading

import numpy as np
import pytest

from brdfkit.brdf import MODELS
from brdfkit.light import EnvironmentMap
from brdfkit.report.atlas import _CARD_CPU_SECONDS, _build_cards, _heaviest_first, default_cards


def test_heaviest_cards_go_first_and_ties_keep_their_order() -> None:
    entries = [(name, []) for name in ("lambertian", "thin_film", "my spec", "torrance_sparrow")]
    # thin_film (2.1 CPU s) before torrance_sparrow (1.7); the two unlisted (1 s) keep their order
    assert _heaviest_first(entries) == [1, 3, 0, 2]


def test_every_default_card_is_scheduled_once() -> None:
    entries = default_cards()
    order = _heaviest_first(entries)
    assert sorted(order) == list(range(len(entries)))
    costs = [_CARD_CPU_SECONDS.get(entries[k][0], 1.0) for k in order]
    assert costs == sorted(costs, reverse=True)
    assert set(_CARD_CPU_SECONDS) <= {title for title, _ in entries}


class _CountingMap(EnvironmentMap):
    """A map that counts how often it is pickled (in the process that pickles it)."""

    pickled = 0

    def __getstate__(self):
        type(self).pickled += 1
        return super().__getstate__()


def _examples_noting_the_process(path: str) -> list:
    with open(path, "a") as f:
        f.write(f"{os.getpid()}\n")
    return [MODELS["lambertian"](), MODELS["phong"]()]


@pytest.mark.skipif(
    len(os.sched_getaffinity(0)) < 2 or threading.active_count() > 1,
    reason="the atlas forks workers only with 2 cores and a single-threaded process",
)
def test_the_workers_get_the_map_once_not_with_every_card(tmp_path):
    # pickled with every card, each card's map would be a new object: env_quadrature's cache
    # of its cell averages (keyed by the object) would miss on every card
    env = _CountingMap(np.ones((8, 16, 3)))
    noted = tmp_path / "pids"
    entries = [(t, functools.partial(_examples_noting_the_process, str(noted))) for t in "abc"]
    options = {"envmap": env, "resolution": 8, "samples": 4, "run_checks": False}
    # _build_cards forks only from a single-threaded process (earlier tests may have left
    # threads, e.g. the kernels' pool): then the cards are built here, and nothing is pickled
    forks = threading.active_count() == 1
    cards = _build_cards(entries, options, None)
    assert [c.title for c in cards] == ["a", "b", "c"] and _CountingMap.pickled == 0
    pids = set(noted.read_text().split())
    if forks:
        assert str(os.getpid()) not in pids and 1 <= len(pids) <= 2  # built by forked workers
    else:
        assert pids == {str(os.getpid())}
