"""`python -m ecostudy ...`: the same command line as the `ecostudy` console script."""
from .cli import app

app()
