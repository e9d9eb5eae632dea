"""The interactive BRDF explorer: ``brdfkit explore`` in the browser, :class:`Explorer` in
notebooks.

Rendering happens in Python — every view comes from the BRDF's own ``eval`` and
:func:`brdfkit.render.shade`, so measured and user-defined BRDFs look exactly as they render —
and the front end (static ES modules in ``static/``, no build step) draws the arrays it gets.

Modules: :mod:`.views` (what each view computes), :mod:`.model_tree` (BRDFs as the JSON trees the
sliders edit), :mod:`.protocol` (checked messages, binary frames), :mod:`.session` (the files and
replies of one page), :mod:`.server` (the local, token-guarded web server), :mod:`.widget` (the
notebook widget).
"""

from __future__ import annotations

from typing import Any

__all__ = ["Explorer"]


def __getattr__(name: str) -> Any:
    if name == "Explorer":  # anywidget is imported only when a notebook asks for the widget
        from brdfkit.explore.widget import Explorer

        return Explorer
    raise AttributeError(name)
