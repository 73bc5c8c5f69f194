"""A command's start without the cyclic garbage collector's passes over its imports.

Importing what ``ecostudy solve`` needs (Pyomo, SciPy, pandas, pydantic's schemas, ...) creates
some 240 000 objects; Python's collector went over them about 350 times while they loaded, twice
in full: 0.19-0.21 s of CPU of the default study's 1.3-1.8 s of imports (``gc.callbacks``, the
machine busy with other work; ``docs/speed.md``), and its first full passes during the solve
0.04-0.07 s more. The ``ecostudy`` command pauses the collector first thing (:func:`pause`);
once the command's module and its libraries are loaded (:mod:`ecostudy.api` resolves it),
:func:`resume` moves every object then alive to the permanent generation (``gc.freeze``), which
the collector never scans again, and switches it back on for the work itself. Freezing keeps
whatever cyclic garbage the imports left for the life of the process: the command's only, which
ends with the work. Nothing happens in a process that did not :func:`pause` (the Python API, the
tests), so a notebook's collector is left as it is.
"""
import gc

_paused = [False]


def pause() -> None:
    """Switch the collector off until :func:`resume` (the ``ecostudy`` command's first step)."""
    if gc.isenabled():
        gc.disable()
        _paused[0] = True


def resume() -> None:
    """Freeze what is loaded and switch the collector on again, if :func:`pause` switched it off."""
    if _paused[0]:
        _paused[0] = False
        gc.freeze()
        gc.enable()
