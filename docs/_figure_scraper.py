"""A sphinx-gallery image scraper for the figures brdfkit's plot functions return.

:mod:`brdfkit.plot` builds :class:`matplotlib.figure.Figure` objects without pyplot (so that it
is safe in servers and threads), and the stock scraper only sees pyplot's figures. This one
shows every ``Figure`` that an example holds in a global variable, once, in the order the
variables were bound.
"""

from __future__ import annotations

from matplotlib.figure import Figure


def _scrape(block, block_vars, gallery_conf):
    from sphinx_gallery.scrapers import figure_rst

    paths = []
    for value in list(block_vars["example_globals"].values()):
        figures = value if isinstance(value, list | tuple) else [value]
        for fig in figures:
            if isinstance(fig, Figure) and not getattr(fig, "_brdfkit_scraped", False):
                path = next(block_vars["image_path_iterator"])
                fig.savefig(path, dpi=100)
                fig._brdfkit_scraped = True
                paths.append(path)
    return figure_rst(paths, gallery_conf["src_dir"])


def _get_sg_image_scraper():
    return _scrape
