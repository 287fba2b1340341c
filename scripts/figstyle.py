#!/usr/bin/env python3
"""The look of every poolreps figure, and what every plot script shares.

Import it before matplotlib; it finds a Python that has matplotlib first:

    import figstyle as fs            # re-runs the script under another Python if needed
    import matplotlib.pyplot as plt  # after figstyle

    fs.setup()                                   # fonts, sizes, palette, colour maps
    fig, ax = fs.figure("half", 0.75)            # 3.6 in wide, height 0.75 x width
    ax.plot(x, y, color=fs.PALETTE["blue"])
    ax.set_xlabel(fs.label("episodes"))
    ax.set_ylabel(fs.label("return", "m"))       # -> "return [m]"
    written = fs.save(fig, "results/exp4", "fig_exp4")   # PNG + SVG, byte-reproducible
    fs.finish("results/exp4", written, ["fig_exp4"])     # drop stale figures, print paths

Conventions (the README and the report rely on them):
  - units in square brackets after the quantity: "distance [m]"; counts have none;
  - colours from the Okabe-Ito palette (PALETTE), distinguishable with the common
    colour-vision deficiencies; grey for references (baselines);
  - colour maps: CMAP (viridis) for sequential data, CMAP_DIVERGING (coolwarm) for
    signed differences; both keep lightness monotone (or symmetric) so that they
    read in grey scale and with colour-vision deficiencies; never jet;
  - sizes: WIDTH["full"] (7.2 in) for figures that span a page, WIDTH["half"]
    (3.6 in) for a figure that sits beside another; PNG at DPI (150);
  - every figure is written as PNG and SVG with the same stem, with no date,
    version or random id inside, so that a rerun on the same CSVs gives the same
    bytes (tests/test_figures.py checks this).
"""
import bad_data  # noqa: F401 (bad input: one line, exit 2, no traceback)
import os
import subprocess
import sys

_REEXEC = "POOLREPS_PLOT_REEXEC"


def _has_matplotlib(python):
    try:
        return subprocess.run([python, "-c", "import matplotlib, numpy"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                              timeout=60).returncode == 0
    except (OSError, subprocess.SubprocessError):
        return False


def python_candidates():
    """Pythons to try, in order: $PYTHON, /usr/bin/python3 (Debian's, which
    python3-matplotlib serves), then every python3 on PATH."""
    out = [os.environ.get("PYTHON", ""), "/usr/bin/python3"]
    for d in os.environ.get("PATH", "").split(os.pathsep):
        out.append(os.path.join(d or ".", "python3"))
    seen, res = set(), []
    for p in out:
        if p and p not in seen and os.access(p, os.X_OK):
            seen.add(p)
            res.append(p)
    return res


def require_matplotlib():
    """Return if this Python imports matplotlib and numpy; otherwise run the
    script again under the first candidate that does (once), or stop with one
    line naming what to install."""
    try:
        import matplotlib  # noqa: F401
        import numpy  # noqa: F401
        return
    except ImportError:
        pass
    script = os.path.basename(sys.argv[0] or "plot")
    if not os.environ.get(_REEXEC):
        for py in python_candidates():
            # a virtual environment's python3 links to the system one but
            # does not see its packages: compare the paths, not the files
            if os.path.abspath(py) != os.path.abspath(sys.executable) and _has_matplotlib(py):
                os.environ[_REEXEC] = "1"
                sys.stdout.flush()
                os.execv(py, [py] + sys.argv)
    sys.exit(f"{script}: no Python with matplotlib and numpy found (tried {sys.executable}, "
             "$PYTHON, /usr/bin/python3, python3 on PATH); install python3-matplotlib")


# only a script of this folder is run again under another Python, never a
# program (a test runner, say) that merely imports this module
if sys.argv and sys.argv[0] and os.path.dirname(os.path.realpath(sys.argv[0])) == \
        os.path.dirname(os.path.realpath(__file__)):
    require_matplotlib()

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib import patheffects  # noqa: E402

# Okabe & Ito (2008), "Color universal design": eight colours that stay apart
# under protanopia, deuteranopia and tritanopia.
PALETTE = {
    "black": "#000000", "orange": "#E69F00", "skyblue": "#56B4E9", "green": "#009E73",
    "yellow": "#F0E442", "blue": "#0072B2", "vermillion": "#D55E00", "purple": "#CC79A7",
    "grey": "#666666", "lightgrey": "#BBBBBB",
}
CYCLE = [PALETTE[k] for k in ("blue", "vermillion", "green", "orange", "skyblue", "purple",
                              "yellow", "black")]
CMAP = "viridis"
CMAP_DIVERGING = "coolwarm"
WIDTH = {"full": 7.2, "half": 3.6}
DPI = 150
FIGURE_EXTS = (".png", ".svg", ".pdf")


def setup():
    """Set matplotlib's defaults for every poolreps figure (call once)."""
    plt.rcdefaults()
    plt.rcParams.update({
        "font.family": "DejaVu Sans",
        "font.size": 9,
        "axes.titlesize": 9.5,
        "axes.labelsize": 9,
        "xtick.labelsize": 8,
        "ytick.labelsize": 8,
        "legend.fontsize": 7.5,
        "legend.framealpha": 0.9,
        "figure.titlesize": 10.5,
        "axes.prop_cycle": matplotlib.cycler(color=CYCLE),
        "axes.grid": True,
        "grid.alpha": 0.3,
        "grid.linewidth": 0.6,
        "image.cmap": CMAP,
        "savefig.dpi": DPI,
        "figure.dpi": DPI,
        "svg.hashsalt": "poolreps",  # fixed ids inside the SVG
        "svg.fonttype": "path",
    })


def figure(width="full", aspect=0.6, **subplots):
    """plt.subplots with width WIDTH[width] (or inches) and height aspect x width.
    Extra keywords go to plt.subplots (nrows, ncols, sharex, gridspec_kw, ...)."""
    w = WIDTH.get(width, width) if isinstance(width, str) else float(width)
    subplots.setdefault("layout", "constrained")
    return plt.subplots(figsize=(w, w * aspect), **subplots)


def legend_below(fig, handles, labels=None, ncol=3, height=0.12, **kw):
    """A figure legend centred under the axes, in a band of height (a
    fraction of the figure) that the constrained layout keeps free."""
    fig.get_layout_engine().set(rect=(0, height, 1, 1 - height))
    if labels is None:
        labels = [h.get_label() for h in handles]
    return fig.legend(handles, labels, loc="lower center", bbox_to_anchor=(0.5, 0.005),
                      ncol=ncol, **kw)


def outlined(colour="white", width=2.4):
    """Keywords that give a light line a thin dark outline, so that it shows on
    the felt and on a white legend alike: ax.plot(..., **fs.outlined())."""
    return {"color": colour, "path_effects": [
        patheffects.Stroke(linewidth=width, foreground="black"), patheffects.Normal()]}


def label(quantity, unit=None):
    """Axis label with its unit in brackets: label("return", "m") -> "return [m]"."""
    return f"{quantity} [{unit}]" if unit else quantity


def save(fig, directory, stem):
    """Write directory/stem.png and directory/stem.svg without dates, versions
    or random ids (same CSVs, same bytes), close fig, return both paths."""
    paths = []
    for ext, meta in ((".png", {"Software": None}),
                      (".svg", {"Date": None, "Creator": None})):
        p = os.path.join(directory, stem + ext)
        fig.savefig(p, metadata=meta)
        paths.append(p)
        # the layout the PNG was drawn with is the SVG's too: solving the
        # constrained layout again took 40 % of all the drawing time
        fig.set_layout_engine("none")
    plt.close(fig)
    return paths


def finish(directory, written, stems, prog=None):
    """After a plot script drew its figures: remove every figure file in
    directory whose stem is one this script can draw (stems) but that it did
    not write now (a leftover of an earlier run on other CSVs), warn about
    other figure files it did not write, and print the written paths."""
    prog = prog or os.path.basename(sys.argv[0])
    keep = {os.path.abspath(p) for p in written}
    for name in sorted(os.listdir(directory)):
        stem, ext = os.path.splitext(name)
        path = os.path.join(directory, name)
        if ext not in FIGURE_EXTS or os.path.abspath(path) in keep:
            continue
        if stem in stems:
            os.remove(path)
            print(f"{prog}: removed stale {path} (not drawn from these CSVs)", file=sys.stderr)
        else:
            print(f"{prog}: note: {path} was not drawn by this script", file=sys.stderr)
    for p in written:
        print(p)


if __name__ == "__main__":
    print(__doc__)
