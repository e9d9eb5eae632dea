"""The atlas hands its cards to the workers heaviest first (longest processing time first)."""

from __future__ import annotations

from brdfkit.report import _CARD_CPU_SECONDS, _heaviest_first, default_cards


def test_heaviest_cards_go_first_and_ties_keep_their_order() -> None:
    entries = [(name, []) for name in ("lambertian", "thin_film", "my spec", "torrance_sparrow")]
    # thin_film (5.2 CPU s) before torrance_sparrow (2.6); the two unlisted (1 s) keep their order
    assert _heaviest_first(entries) == [1, 3, 0, 2]


def test_every_default_card_is_scheduled_once() -> None:
    entries = default_cards()
    order = _heaviest_first(entries)
    assert sorted(order) == list(range(len(entries)))
    costs = [_CARD_CPU_SECONDS.get(entries[k][0], 1.0) for k in order]
    assert costs == sorted(costs, reverse=True)
    assert set(_CARD_CPU_SECONDS) <= {title for title, _ in entries}
