"""One look for every figure: a colour per strategy, distribution, series kind and limit kind, a
palette for unnamed series that never repeats a colour within one figure, and one way to save a
figure (PNG, SVG or PDF at a chosen resolution).

``colour(name)`` gives the same colour for the same name in every plot (the speed limit is the
same red in the run, the front, the comparison and the journey); ``Palette`` hands out colours
within one figure: a named series keeps its colour, every other series gets one that no series
of that figure has yet.
"""
import colorsys
from pathlib import Path
from typing import NamedTuple

from ecostudy.core.errors import InputError, problem
from ecostudy.io.writers import atomic_write

# Limits and references drawn behind the series.
LIMIT = {
    "speed limit": "#d62728",     # red
    "gradient": "#8c564b",        # brown
    "timing point": "#e7298a",    # magenta
    "stop": "#7f7f7f",            # grey: stops, segment ends, zero lines
    "budget": "#a50f15",          # dark red: the real-time budget of a controller
    "voltage limit": "#636363",   # dark grey: nominal and highest line voltage
    "not ok": "#99000d",          # darkest red: a title or a mark of a run that is not ok
    "title": "#1a1a1a",           # near black: a title of a run that is ok
}

# Strategies side by side (``compare``) and the runs of one solve.
STRATEGY = {
    "all-out": "#9467bd",
    "ATO optimum": "#1f77b4",
    "eco-drive coasting": "#2ca02c",
    "MARECO-style": "#ff7f0e",
    "DAS round (nearest level)": "#e377c2",
    "DAS phases": "#17becf",
    "DAS minlp": "#bcbd22",
    "re-simulated": "#000000",
}

# Distributions of a journey's running time.
DISTRIBUTION = {
    "whole-journey NLP": "#1f77b4",
    "equal marginal saving": "#2ca02c",
    "same percentage": "#9467bd",
    "MARECO-style": "#ff7f0e",
    "as timetabled": "#000000",
    "timing windows NLP": "#17becf",
}

# Trains on one substation: the network strategies.
NETWORK = {
    "independent": "#000000",
    "joint": "#1f77b4",
    "receptivity": "#ff7f0e",
    "triggering": "#2ca02c",
    "voltage": "#9467bd",
    "dissension": "#e377c2",
    "following": "#bcbd22",
}

# Kinds of series: what a curve of a front or a profile is.
KIND = {
    "traction": "#1f77b4",        # traction energy at the wheel, the optimal profile
    "net energy": "#2ca02c",      # net electrical energy, regeneration credited
    "DAS advice": "#ff7f0e",      # driver advice re-simulated
    "weighted sum": "#9467bd",    # points of the weighted-sum objective
    "study time": "#c51b7d",      # the study's own running time on its front
    "marginal saving": "#17becf",
    "handle": "#bcbd22",          # the handle u beneath a run
    "reference": "#000000",       # a reference a controller tracks (heavy haul's single-mass optimum)
}

# Closed-loop controllers by kind (``io.loopfile.CONTROLLER_KINDS``): a controller named after its
# kind has this colour in every closed-loop plot; two controllers of one kind get a colour each.
CONTROLLER = {
    "convex": "#1f77b4",
    "open_loop": "#bcbd22",
    "ato": "#2ca02c",
    "sbpc": "#ff7f0e",
    "sppc": "#9467bd",
    "rspc": "#17becf",
}

# Handle regimes shaded beneath a run.
REGIME = {
    "cruise": "#1f77b4",
    "coast": "#7f7f7f",
    "traction": "#2ca02c",
    "braking": "#e377c2",
    "full service braking": "#d62728",
}

# Parts of a run's energy flow (analysis.energyflow).
ENERGY = {
    "drawn from the line": "#1f77b4",
    "losses in traction": "#aec7e8",
    "traction at the wheel": "#08519c",
    "resistance": "#ff7f0e",
    "potential energy": "#8c564b",
    "kinetic energy": "#bcbd22",
    "regeneration returned": "#2ca02c",
    "braking dissipated": "#d62728",
    "net from the line": "#000000",
}

GROUPS = {"limit": LIMIT, "strategy": STRATEGY, "distribution": DISTRIBUTION, "network": NETWORK,
          "kind": KIND, "controller": CONTROLLER, "regime": REGIME, "energy": ENERGY}

# colour(name) looks a name up in this order: a limit, then a strategy, ... (the same name in two
# tables, e.g. "MARECO-style", has the same colour in both)
_ORDER = (LIMIT, STRATEGY, DISTRIBUTION, NETWORK, KIND, CONTROLLER, REGIME, ENERGY)

# Colours for unnamed series, in the order handed out: matplotlib's tab10 without the limits'
# red, brown and grey, then Dark2 (ordered so that colours handed out one after the other are far
# apart: the trains of a network figure after its seven strategies) and the light tab20 shades;
# beyond these, generated hues.
_FRESH = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#e377c2", "#bcbd22", "#17becf", "#d95f02",
          "#7570b3", "#1b9e77", "#e6ab02", "#66a61e", "#a6761d", "#aec7e8", "#ffbb78", "#98df8a",
          "#c5b0d5", "#f7b6d2", "#dbdb8d", "#9edae5")

DIVERGING = "RdBu_r"  # colour map of a signed field (in-train forces: compression blue, tension red)

DASHES = ("-", "--", "-.", ":")  # line styles cycled with the colours where curves overlap

FORMATS = ("png", "svg", "pdf")
DPI = 110  # default resolution [dots per inch] of a raster figure


def colour(name):
    """The colour of a named strategy, distribution, network strategy, series kind, regime,
    energy part or limit kind, as a hex string; ``KeyError`` naming the known names otherwise."""
    for table in _ORDER:
        if name in table:
            return table[name]
    known = sorted({n for table in _ORDER for n in table})
    raise KeyError(f"no colour for {name!r}; named: {', '.join(known)}")


def sequence(count):
    """``count`` colours along a sequential map (viridis, its bright end left out): series in an
    order, e.g. the points of a front from fastest to slowest."""
    from matplotlib import colormaps  # style.output and the colour tables need no matplotlib
    cmap = colormaps["viridis"]
    return [_hex(cmap(0.9 * i / max(count - 1, 1))[:3]) for i in range(count)]


def named(name):
    """True when ``name`` has a colour of its own (:func:`colour`)."""
    return any(name in table for table in _ORDER)


def _hex(rgb):
    """#rrggbb of an (r, g, b) triple in [0, 1]."""
    return "#" + "".join(f"{round(255 * x):02x}" for x in rgb)


def _generated():
    """Endless distinct hues (golden-ratio steps round the colour circle, two lightness levels)."""
    n = 0
    while True:
        hue = (0.13 + 0.618034 * n) % 1.0
        light = 0.42 if n % 2 == 0 else 0.62
        yield _hex(colorsys.hls_to_rgb(hue, light, 0.7))
        n += 1


class Palette:
    """The colours of one figure. ``palette(key)`` gives ``key`` its colour: the same key again
    gives the same colour (a train in every panel), a named key (:func:`colour`) its own colour,
    any other key, or ``None``, the next colour that no series of this figure has. The limit
    colours are never handed out. ``keys`` given at the start are served first, so the named ones
    among them keep their colour whatever order the rest are asked in."""

    def __init__(self, keys=()):
        self._given = {}
        self._used = {c.lower() for c in LIMIT.values()}
        self._fresh = iter(_FRESH)
        self._more = _generated()
        keys = list(keys)
        for key in keys:
            if named(key) and colour(key).lower() not in self._used:
                self._take(key, colour(key))
        for key in keys:
            self(key)

    def _take(self, key, c):
        self._used.add(c.lower())
        if key is not None:
            self._given[key] = c
        return c

    def _next(self):
        for c in self._fresh:
            if c.lower() not in self._used:
                return c
        for c in self._more:
            if c.lower() not in self._used:
                return c

    def __call__(self, key=None):
        if key is not None and key in self._given:
            return self._given[key]
        if key is not None and named(key) and colour(key).lower() not in self._used:
            return self._take(key, colour(key))
        return self._take(key, self._next())

    @property
    def used(self):
        """The colours handed out so far (lower-case hex)."""
        return set(self._given.values())


class Output(NamedTuple):
    """How figures are written: ``fmt`` one of :data:`FORMATS`, ``dpi`` dots per inch (raster
    images; SVG and PDF are vector graphics and use it only for embedded images)."""

    fmt: str = "png"
    dpi: float = DPI

    def filename(self, stem):
        """The file name of a figure: ``stem`` with this format's suffix (``speed`` -> ``speed.svg``)."""
        return f"{stem}.{self.fmt}"

    def filenames(self, stems, plot=True):
        """The file names of the figures ``stems`` (:meth:`filename`; none where ``plot`` is False:
        none is drawn), as a command names them to check its output folder before computing
        (:func:`ecostudy.io.writers.check_output_dir`)."""
        return tuple(self.filename(stem) for stem in stems) if plot else ()


def output(fmt="png", dpi=None, option="--format"):
    """A checked :class:`Output`: an unknown format or a resolution outside 10-2400 dpi is an
    ``InputError`` naming the option (``--format``, ``--dpi``) and the allowed values."""
    fmt = str(fmt).lower().lstrip(".")
    if fmt not in FORMATS:
        raise InputError(problem("command line", option, f"{fmt!r} is not a figure format; use one of "
                                 f"{', '.join(FORMATS)}"))
    dpi = DPI if dpi is None else dpi
    if not 10 <= float(dpi) <= 2400:
        raise InputError(problem("command line", "--dpi", f"{dpi:g} is outside 10-2400 dots per inch"))
    return Output(fmt, float(dpi))


def ring(ax, x, y, label=None):
    """Ring the points (``x``, ``y``) of runs that are not ok on ``ax``, in the colour of a run not ok
    (a front or a trade-off of such points is no result to quote)."""
    ax.plot(x, y, "o", ms=12, mfc="none", mec=LIMIT["not ok"], mew=1.5, label=label)


def save(fig, path, fmt=None, dpi=None):
    """Write ``fig`` to ``path`` as ``fmt`` (png, svg or pdf; None: the path's suffix if it is
    one of these, else png) at ``dpi`` (None: :data:`DPI`), atomically (:func:`atomic_write`: a
    drawing stopped by a signal or an error leaves neither part of a figure under ``path`` nor a
    temporary file), and return None; with no ``path`` return the figure (a notebook shows it)."""
    if path is None:
        return fig
    if fmt is None:
        suffix = str(path).rsplit(".", 1)[-1].lower() if "." in str(path) else ""
        fmt = suffix if suffix in FORMATS else "png"
    out = output(fmt, dpi)
    metadata = {"png": {"Software": None}, "svg": {"Date": None}, "pdf": {"CreationDate": None}}[out.fmt]
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=out.dpi, format=out.fmt, metadata=metadata))
    return None


def names(stem):
    """The file names a figure ``stem`` may have in any format (to remove an earlier run's)."""
    return [f"{stem}.{fmt}" for fmt in FORMATS]


def write(out_dir, stem, draw, out=Output()):
    """Write the figure that ``draw(path, fmt=..., dpi=...)`` saves (any plot function with its
    data bound, e.g. ``functools.partial(plots.speed_plot, result)``) as ``stem.<fmt>`` in
    ``out_dir``, atomically (:func:`save`), and remove the same figure in the other formats (:func:`remove`);
    returns the file name written."""
    out_dir = Path(out_dir)
    name = out.filename(stem)
    draw(out_dir / name, fmt=out.fmt, dpi=out.dpi)
    remove(out_dir, stem, keep=name)
    return name


def remove(out_dir, stem, keep=None):
    """Remove the figure ``stem`` of ``out_dir`` in every format but the file ``keep`` (an earlier
    run's); a folder of such a name is no figure and stays."""
    for name in names(stem):
        path = Path(out_dir) / name
        if name != keep and not path.is_dir():
            path.unlink(missing_ok=True)
