"""``brdfkit explore [SPEC_OR_FILE ...]``: the interactive BRDF explorer in the browser."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from brdfkit.cli._app import app, fail, shown, status

_Items = Annotated[
    list[str] | None,
    typer.Argument(
        metavar="[SPEC_OR_FILE]...",
        help='Model specs ("ggx(alpha=0.1)"), measured files (MERL .binary, RGL .bsdf, '
        "Cornell .brdf) and fit.json results of brdfkit fit to show, and meshes (.obj, .ply, "
        ".stl, .gltf, .glb) for the lit-object view; the default is a Lambertian + GGX.",
    ),
]
_Envmap = Annotated[
    Path | None,
    typer.Option(
        "--envmap",
        metavar="FILE",
        help="Lat-long .hdr/.exr map of the environment-lit sphere (default: the bundled one).",
    ),
]
_Port = Annotated[
    int, typer.Option("--port", metavar="N", help="Port on 127.0.0.1 (0: a free one).")
]
_NoBrowser = Annotated[
    bool,
    typer.Option("--no-browser", help="Print the address instead of opening a browser."),
]


@app.command("explore")
def explore_command(
    items: _Items = None,
    envmap: _Envmap = None,
    port: _Port = 0,
    no_browser: _NoBrowser = False,
) -> None:
    """Open the explorer: lit spheres (drag to move the light), the 3D lobe, the polar plot, the
    θh/θd/θv curves, the albedo and the θh×θd slice of several BRDFs at once.

    The server listens on 127.0.0.1 only; its address carries a random token, checked on every
    request, and it reads only the files named here or uploaded through the page. Stop it with
    Ctrl-C.
    """
    from brdfkit.brdf.spec import parse
    from brdfkit.explore.server import ExplorerServer
    from brdfkit.explore.session import MEASURED_SUFFIXES, Session, fit_spec
    from brdfkit.render.mesh import MESH_SUFFIXES

    if not 0 <= port <= 65535:
        fail(f"--port must be in [0, 65535]; got {port}")
    session = Session(envmap)
    initial = []
    for item in items or []:
        if Path(item).suffix.lower() in MEASURED_SUFFIXES:
            initial.append(session.add_file(item))
        elif Path(item).suffix.lower() in MESH_SUFFIXES:
            session.add_mesh(item)  # in the lit-object view's menu of meshes
        elif Path(item).suffix.lower() == ".json":
            initial.append(fit_spec(Path(item).read_bytes(), item))
        else:
            parse(item)  # a bad spec is refused now, with the parser's message
            initial.append(item)
    try:
        server = ExplorerServer(session, initial or [], port=port)
    except OSError as error:
        fail(f"--port {port}: cannot listen on 127.0.0.1: {error.strerror or error}")
    status.print(f"brdfkit explore: {shown(server.url)}  (Ctrl-C stops it)", soft_wrap=True)
    if not no_browser:
        import webbrowser

        webbrowser.open(server.url)
    try:
        server.serve_forever()
    finally:
        session.close()
