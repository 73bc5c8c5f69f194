"""What a refusal of a function of :mod:`ecostudy.api` names: the argument as a Python caller spells
it (``arguments: time: must be more than 0.0, not -5``), or, when the command line called it
(:func:`command_line`), its option (``command line: --time: ...``).

The checks shared with the command line (``studies.options``, the study engine, the figure
options) name the command line's options; :func:`spelled` turns their lines into the arguments of
the function that raised them: ``command line`` becomes ``arguments`` and each option, in the field
and in the text, the argument that sets it (``--from`` -> ``from_stop``, ``--format`` ->
``fig_format``, ``--das-time-limit`` -> ``das_time_limit``); an option the function has no argument
for (``--force``) is left as it is.
"""
import contextvars
import functools
import inspect
import re
import typing
import warnings
from collections import abc
from contextlib import contextmanager
from os import PathLike
from pathlib import Path
from typing import Any, Callable, Iterator, TypeVar

from ecostudy.core.errors import EcostudyWarning, InputError, problem
from ecostudy.io.documents import not_a_path

F = TypeVar("F", bound=Callable[..., Any])
CALLER: contextvars.ContextVar[str] = contextvars.ContextVar("ecostudy_caller", default="arguments")
# the options not spelled as their argument ('-' -> '_'); a size guard's field 'study' is the whole work, no argument
ARGUMENT = {"from": "from_stop", "to": "to_stop", "format": "fig_format", "no-plot": "plot=False", "study": ""}
OPTION = re.compile(r"(?<![\w-])--([a-z][a-z0-9-]*)")
FIELD = re.compile(r"^(command line|arguments): ([^:]+): ")


@contextmanager
def command_line() -> Iterator[None]:
    """Within this block the functions of :mod:`ecostudy.api` name the command line's options in
    their refusals (``command line: --time``), as ``ecostudy`` prints them."""
    token = CALLER.set("command line")
    try:
        yield
    finally:
        CALLER.reset(token)


def path_arguments(signature: inspect.Signature) -> dict[str, tuple[bool, bool]]:
    """The arguments a path is given for (annotated ``Path``, ``Optional[Path]``, ``Sequence[Path] |
    Path | str``): name -> (None allowed, a list of paths allowed)."""
    out = {}
    for name, parameter in signature.parameters.items():
        kinds = list(typing.get_args(parameter.annotation)) or [parameter.annotation]
        if Path in kinds:
            out[name] = (type(None) in kinds, any(typing.get_origin(k) in (list, tuple, abc.Sequence) for k in kinds))
    return out


def check_paths(signature: inspect.Signature, paths: dict[str, tuple[bool, bool]], args: tuple, kwargs: dict) -> None:
    """Refuse a value given for a path argument that is none (``api.load(None)``, ``out=5``), one line
    each naming the argument (Path() raised TypeError); a call that does not bind is left to Python."""
    try:
        given = signature.bind_partial(*args, **kwargs).arguments
    except TypeError:
        return
    lines = []
    for name, (optional, listed) in paths.items():
        value = given.get(name, signature.parameters[name].default)
        items = value if listed and isinstance(value, (list, tuple)) else [value]
        if value is inspect.Parameter.empty or (value is None and optional):
            continue
        if not items or not all(isinstance(x, (str, PathLike)) for x in items):
            lines.append(problem("arguments", name, not_a_path(name, value)))
    if lines:
        raise InputError(lines)


def spelled(function: F) -> F:
    """``function`` whose :class:`~ecostudy.core.errors.InputError` lines and warnings name its
    arguments, not the command line's options (outside :func:`command_line`); a value given for a
    path argument that is none is refused naming the argument (:func:`check_paths`)."""
    signature = inspect.signature(function)
    names, paths = set(signature.parameters), path_arguments(signature)

    def argument(option: str) -> str | None:  # the argument that sets an option (or a field), if the function has it
        name = ARGUMENT.get(option, option.replace("-", "_"))
        return name if name and name.split("=")[0] in names else None

    def field(match: re.Match) -> str:  # 'a/b', '--objective time' (a value), 'stops[1]' (an item)
        parts = [re.fullmatch(r"(?:--)?([a-z][a-z0-9_-]*)( .*)?(\[.*)?", p) for p in match.group(2).split("/")]
        args = [argument(p[1]) if p else None for p in parts]
        if not all(args):  # not the command line's field, or not this function's argument: as it is
            return match.group(0)
        shown = [f"{a}={p[2].strip()!r}" if p[2] else f"{a}{p[3] or ''}" for a, p in zip(args, parts) if p]
        return f"arguments: {'/'.join(shown)}: "

    def line(text: str) -> str:
        text = FIELD.sub(field, text, count=1)
        return OPTION.sub(lambda m: argument(m.group(1)) or m.group(0), text)

    @functools.wraps(function)
    def named(*args: Any, **kwargs: Any) -> Any:
        if CALLER.get() != "arguments":  # the command line's own words
            return function(*args, **kwargs)
        check_paths(signature, paths, args, kwargs)
        caught: list[warnings.WarningMessage] = []
        try:
            with warnings.catch_warnings(record=True) as caught:  # its warnings named alike, given on below
                warnings.simplefilter("always")
                return function(*args, **kwargs)
        except InputError as exc:
            exc.problems = [line(p) for p in exc.problems]
            exc.args = ("\n".join(exc.problems),)
            raise
        finally:
            for w in caught:
                ours = issubclass(w.category, EcostudyWarning)
                warnings.warn(line(str(w.message)) if ours else w.message, w.category, stacklevel=2)

    return named  # type: ignore[return-value]
