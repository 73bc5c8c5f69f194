"""The Typer application and what every command shares: messages through the ``ecostudy`` logger
(``--quiet``, ``--verbose``, ``--log-file``), one-line errors (``--debug``: tracebacks), exit status:
0 ok, 1 written but not ok (flagged or failed cases), 2 bad input or infeasible request, 3 solver
failure or internal error, 130 interrupted (SIGINT), 143 terminated (SIGTERM), 129 hung up (SIGHUP)."""
import logging
import sys
import traceback
import warnings
from pathlib import Path
from typing import Annotated, Optional

import typer

from ecostudy.core.budget import forced
from ecostudy.core.errors import printable
from ecostudy.core.interrupt import exit_status, stopped_by_signals
from ecostudy.core.startup import pause
from ecostudy.report.console import OneLineErrors, interrupted, leave, logging_to, progress_bar

app = typer.Typer(cls=OneLineErrors, add_completion=False, no_args_is_help=True, rich_markup_mode=None,  # "[s]": a unit
                  help="Energy-efficient train control studies (Pyomo + Ipopt).")
log = logging.getLogger("ecostudy")
quiet = [False]  # --quiet of this invocation: no progress


def _print_version(value: bool) -> None:
    if value:
        from ecostudy import __version__
        typer.echo(f"ecostudy {__version__}")
        raise typer.Exit(0)


@app.callback()
def _main(ctx: typer.Context,
          version: Annotated[bool, typer.Option("--version", callback=_print_version, is_eager=True,
                                                help="Print the version and exit.")] = False,
          quiet_: Annotated[bool, typer.Option("--quiet", "-q", help="Quiet stderr: no progress bar and no messages but errors and the reason a result is not ok; the results still print on stdout.")] = False,
          verbose: Annotated[bool, typer.Option("--verbose", "-v", help="Debug messages too (each case).")] = False,
          log_file: Annotated[Optional[Path], typer.Option(help="Also write the messages to this file.")] = None,
          ) -> None:
    """Energy-efficient train control studies (Pyomo + Ipopt)."""
    from ecostudy.ocp.solver import configure
    quiet[0] = quiet_
    ctx.call_on_close(logging_to(quiet_, verbose, log_file))
    log.debug("ecostudy %s", " ".join(sys.argv[1:]))
    configure()  # once, before any command imports the solver chain


def call(debug, name, *args, force=False, bar=None):
    """``ecostudy.api.<name>(*args)``, the size guards lifted when ``force`` (:mod:`ecostudy.core.budget`);
    ``bar``: (label, off[, stored]) of a progress bar passed as ``progress`` (stored False: Ctrl-C keeps
    nothing). Errors: one line and an exit code; warnings: log lines; SIGINT, SIGTERM or SIGHUP: exit status 130, 143 or 129."""
    from ecostudy import api

    with warnings.catch_warnings(record=True) as caught, forced(force), api.command_line(), stopped_by_signals():
        warnings.simplefilter("always")
        try:
            if bar is None:
                return getattr(api, name)(*args)
            with progress_bar(bar[0], bar[1] or quiet[0]) as progress:
                return getattr(api, name)(*args, progress=progress)
        except typer.Exit:
            raise
        except KeyboardInterrupt as exc:
            log.warning(interrupted(exc, bar))
            raise typer.Exit(exit_status())
        except Exception as exc:  # an unexpected failure still gets one line by default
            if debug:
                traceback.print_exc()
            text, code = api.one_line(exc, debug)
            for line in text.rstrip("\n").split("\n"):  # one problem a line; what a user typed, escaped
                log.error(printable(line))
            raise typer.Exit(code)
        finally:
            for w in caught:
                log.warning(str(w.message))


def finish(result):
    """Print a command's report; exit status 1 when its folder has cases that are not ok, each
    named on stderr (:meth:`ecostudy.api.Report.problems`) once, then the status line, last."""
    typer.echo(result.text)
    for line in result.problems():
        typer.secho(line, fg=typer.colors.YELLOW, err=True)
    log.info(f"{result.kind}: {result.status.kind if result.not_ok else result.status}, written to {result.folder.resolve()}")
    if result.not_ok:
        raise typer.Exit(1)


def told(note, code):
    """Print a command's note (:class:`ecostudy.api.Note`); exit status ``code`` when it is not ok."""
    typer.echo(note.text)
    if not note.ok:
        raise typer.Exit(code)


def main() -> None:
    """The ``ecostudy`` command: the collector paused while it loads (:mod:`ecostudy.core.startup`), the application, a quick exit (:func:`ecostudy.report.console.leave`)."""
    pause()
    try:
        app()
    except SystemExit as done:  # the application always ends so
        leave(done.code)
