"""ST14 (bi-polynomial photometric stereo) on the renders of ``bench_ps_materials.py``.

The same DiLiGenT-layout stacks (real DiLiGenT normals and depth, 96 DiLiGenT-like lights,
cast shadows, noise; analytic and measured materials) and, per (object, material), least
squares, :func:`~brdfkit.vision.bivariate_stereo.bipolynomial` as its paper does it (degree
``(1, 0)`` by default) and the same search with the ``l·h`` terms of a ``(3, 1)``
bi-polynomial, which make the residual's minimum ambiguous under these lights. One JSON line
per (object, material, method), then the table; records to ``benchmarks/results/bipolynomial.json``.

    python benchmarks/bench_bipolynomial.py [--objects bear cat pot1] [--step 4]
"""

from __future__ import annotations

import functools
import json

from bench_ps_materials import ANALYTIC, MEASURED, render_arguments, solve_all, table
from brdfkit.vision import bivariate_stereo, photometric_stereo

METHODS = {
    "least_squares": photometric_stereo.least_squares,
    "bipolynomial": bivariate_stereo.bipolynomial,
    "bipolynomial (3, 1)": functools.partial(bivariate_stereo.bipolynomial, degree=(3, 1)),
}


def main() -> None:
    """Render every (object, material), run the three, print JSON lines and the table."""
    args = render_arguments(__doc__.splitlines()[0]).parse_args()
    materials = list(ANALYTIC) + list(MEASURED)
    records = solve_all(args.data, args.objects, args.step, args.noise, materials, METHODS)
    from _machine import header, results_path

    out = results_path(__file__)
    results = {
        **header(__file__),
        "objects": args.objects, "step": args.step, "noise": args.noise,
        "methods": list(METHODS), "materials": materials, "records": records,
    }  # fmt: skip
    out.write_text(json.dumps(results, indent=1) + "\n", encoding="utf-8")
    print(table(records, list(METHODS), materials))


if __name__ == "__main__":
    main()
