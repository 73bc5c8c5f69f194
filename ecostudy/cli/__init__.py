"""Layer 7: the Typer command line, one module per command group; :data:`app` is the entry point."""
from ecostudy.cli import calibrate, heavyhaul, network, simulate, solve, studies  # noqa: F401  (each registers its commands)
from ecostudy.cli.app import app, main

__all__ = ["app", "main"]
