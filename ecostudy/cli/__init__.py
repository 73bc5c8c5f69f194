"""Layer 7: the Typer command line, one module per command group; :data:`app` is the entry point."""
from ecostudy.core.interrupt import quiet_start
quiet_start()  # first, in the command's process only: a stop while the rest loads is one line, not a traceback
from ecostudy.cli import calibrate, heavyhaul, network, simulate, solve, studies  # noqa: E402,F401  (each registers its commands)
from ecostudy.cli.app import app, main  # noqa: E402
__all__ = ["app", "main"]
