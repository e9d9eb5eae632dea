"""The explorer as a notebook widget (Jupyter, VS Code, Colab: any host of anywidget).

The front end is the web page's own ES module (``static/explorer.js``) with a few lines of
glue (``static/widget.js``); messages travel over the widget's comm instead of a WebSocket and
are answered by the same :class:`~brdfkit.explore.session.Session` in the kernel; the
environment-lit spheres' passes are sent from a background thread as they come, the next
message cancelling them.

References
----------
.. [1] T. Manz et al., anywidget, https://anywidget.dev (one ES module for every notebook host).
"""

from __future__ import annotations

import functools
import json
import os
import threading
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from brdfkit.brdf.base import BRDF
from brdfkit.brdf.spec import parse
from brdfkit.errors import require_extra
from brdfkit.explore.protocol import ProtocolError, array_table, parse_object
from brdfkit.explore.session import (
    MEASURED_SUFFIXES,
    Session,
    error_reply,
    fit_spec,
    guarded,
)

anywidget = require_extra("anywidget")
traitlets = require_extra("traitlets", "explore")

_STATIC = Path(__file__).with_name("static")


def _module() -> str:
    """explorer.js followed by the widget glue: one ES module."""
    return (_STATIC / "explorer.js").read_text() + "\n" + (_STATIC / "widget.js").read_text()


class Explorer(anywidget.AnyWidget):
    """The interactive BRDF explorer in a notebook cell.

    Parameters
    ----------
    *items : specs (``"ggx(alpha=0.1)"``), BRDF objects with a spec form, paths of measured
        files (MERL ``.binary``, RGL ``.bsdf``, Cornell ``.brdf``) or of ``fit.json`` results of
        ``brdfkit fit``, shown at once.

    Attributes
    ----------
    state : the front end's whole state as JSON (BRDFs, view, display), updated after each
        frame it shows; the same text that the web page keeps in its URL.

    Examples
    --------
    >>> from brdfkit.explore import Explorer
    >>> Explorer("lambertian(albedo=0.5) + ggx(alpha=0.2)", "gold.binary")  # doctest: +SKIP
    """

    _esm = traitlets.Unicode(_module()).tag(sync=True)
    _css = traitlets.Unicode((_STATIC / "style.css").read_text()).tag(sync=True)
    config = traitlets.Unicode("{}").tag(sync=True)
    state = traitlets.Unicode("{}").tag(sync=True)

    def __init__(self, *items: str | os.PathLike | BRDF, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.session = Session()
        self.config = json.dumps(
            {
                "initial": self._initial(items),
                "files": self.session.files,
                "envmap": self.session.envmap_name,
            }
        )
        self._cancel = threading.Event()
        self._passes: threading.Thread | None = None
        self.on_msg(self._receive)

    def _initial(self, items: Sequence[str | os.PathLike | BRDF]) -> list[str]:
        initial = []
        for item in items:
            if isinstance(item, BRDF):
                initial.append(item.to_spec())
            elif Path(item).suffix.lower() in MEASURED_SUFFIXES:
                initial.append(self.session.add_file(item))
            elif Path(item).suffix.lower() == ".json":
                initial.append(fit_spec(Path(item).read_bytes(), str(item)))
            else:
                initial.append(parse(str(item)).to_spec())
        return initial

    def handle(self, content: Any) -> list[tuple[dict[str, Any], list[bytes]]]:
        """The replies (header, buffers) to one message from the front end."""
        seq = content.get("seq", 0) if isinstance(content, dict) else 0
        seq = seq if isinstance(seq, int) and not isinstance(seq, bool) else 0
        try:
            message = parse_object(content)
        except ProtocolError as error:
            replies = [error_reply(seq, error)]
        else:
            replies = self.session.handle(message)  # every failure an error reply
        out = []
        for header, arrays in replies:
            _, buffers = array_table(arrays)
            out.append((header, buffers))
        return out

    def environment(
        self, content: Any, cancel: threading.Event
    ) -> Iterator[tuple[dict[str, Any], list[bytes]]]:
        """The environment-lit spheres of a render message, pass by pass
        (:meth:`Session.environment`), until ``cancel`` is set; nothing for another message
        or with the environment view off."""
        try:
            message = parse_object(content)
        except ProtocolError:
            return
        if message.type != "render":
            return
        passes = self.session.environment(message, cancel)
        while (reply := guarded(message.seq, functools.partial(next, passes, None))) is not None:
            header, arrays = reply
            yield header, array_table(arrays)[1]
            if header["type"] == "error":
                return  # the passes failed: answered

    def _receive(self, _widget: Any, content: Any, _buffers: list[Any]) -> None:
        self._cancel.set()  # a newer message stops the passes under way
        for header, buffers in self.handle(content):
            self.send(header, buffers)
        if isinstance(content, dict) and content.get("type") == "render":
            cancel = self._cancel = threading.Event()

            def send_passes() -> None:
                for header, buffers in self.environment(content, cancel):
                    self.send(header, buffers)

            self._passes = threading.Thread(target=send_passes, daemon=True)
            self._passes.start()

    def close(self) -> None:
        """Close the widget, stop its passes and remove its session's uploads."""
        self._cancel.set()
        self.session.close()
        super().close()


__all__ = ["Explorer"]
