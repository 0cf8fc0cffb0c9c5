"""sphinx-gallery image scraper for figures made without pyplot.

The package draws its figures as plain :class:`matplotlib.figure.Figure` objects (no pyplot, no
figure manager: :mod:`controllers.report.figures`), which sphinx-gallery's ``matplotlib`` scraper
(it lists ``pyplot.get_fignums()``) does not see. This scraper looks after each code block of an
example for Figure objects newly bound to a global name of the script, saves each once, and shows it
below the block, in the order the names were bound.
"""

from __future__ import annotations

import weakref

_SEEN: "weakref.WeakSet" = weakref.WeakSet()


def pyplot_free_figures(block, block_vars, gallery_conf) -> str:
    """Save the Figure objects a code block bound to new names; return their reST (sphinx-gallery scraper API)."""
    from matplotlib.figure import Figure
    from sphinx_gallery.scrapers import figure_rst

    paths = []
    for value in list(block_vars["example_globals"].values()):
        if isinstance(value, Figure) and value not in _SEEN:
            _SEEN.add(value)
            path = next(block_vars["image_path_iterator"])
            value.savefig(path, dpi=80)
            paths.append(path)
    return figure_rst(paths, gallery_conf["src_dir"]) if paths else ""
