"""The files shipped with ecostudy (``tracks/``, ``trains/``, ``studies/`` of its repository), found
from the working directory, a folder above it, or the checkout the package is installed from."""
from pathlib import Path

from ecostudy.core.errors import InputError, problem

CHECKOUT = Path(__file__).resolve().parents[2]  # ecostudy/io/shipped.py: the folder that holds ecostudy/


def shipped(name: str) -> Path:
    """The path of the shipped file ``name``, e.g. ``"tracks/amsterdam_rokin_centraal.yaml"``: the
    first of the working directory, each folder above it and the checkout beside the installed
    package (an install in place, ``make install``) that holds it; an :class:`InputError` naming
    where it looked otherwise (a package installed from a wheel ships no tracks)."""
    here = Path.cwd()
    for root in (here, *here.parents, CHECKOUT):
        if (root / name).exists():
            return root / name
    raise InputError(problem("arguments", "name", f"{name} is not in {here}, a folder above it or {CHECKOUT}; "
                             "run from a checkout of the repository or give the file's path"))
