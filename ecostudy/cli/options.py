"""Options that several commands share, declared once (``Annotated`` types for Typer)."""
from enum import Enum
from pathlib import Path
from typing import Annotated, Optional

import typer

from ecostudy.core.defaults import FRONT_POINTS, RUN_POINTS

# the choices of --das and --objective (a str Enum each, as Typer lists them in the help)
DasMethod = Enum("DasMethod", {"round": "round", "phases": "phases", "minlp": "minlp"}, type=str)
Objective = Enum("Objective", {"energy": "energy", "net_energy": "net_energy", "time": "time", "mixed": "mixed"}, type=str)

Study = Annotated[Optional[Path], typer.Argument(help="Study file (YAML).")]
Track = Annotated[Optional[Path], typer.Option(help="Track file (YAML, or TTOBench JSON).")]
Train = Annotated[Optional[Path], typer.Option(help="Train file (YAML, or TTOBench/OSRD JSON).")]
From = Annotated[Optional[str], typer.Option("--from", help="Departure stop (default: first; a study file sets its own).")]
To = Annotated[Optional[str], typer.Option("--to", help="Arrival stop (default: last; a study file sets its own).")]
Time = Annotated[Optional[float], typer.Option("--time", help="Running time [s].")]
Supplement = Annotated[Optional[float], typer.Option(help="Running-time supplement over all-out [%].")]
Points = Annotated[Optional[int], typer.Option("--points", "-K", help="Grid nodes K (default: the study's, else "
                                                                      f"{RUN_POINTS}; {FRONT_POINTS} for a front).")]
_OUT = "Output folder (relative: to the working directory; default: {}).".format  # each command's own default
Out = Annotated[Optional[Path], typer.Option(help=_OUT("the study's 'output', else out/NAME (the study's name)"))]
RunOut = Annotated[Optional[Path], typer.Option(help=_OUT("the study's 'output', '_pareto' or '_compare' added for those kinds"))]
SolveOut = Annotated[Optional[Path], typer.Option(help=_OUT("the study's 'output', else out/TRACK_FROM_TO"))]
ParetoOut = Annotated[Optional[Path], typer.Option(help=_OUT("the study's 'output' with '_pareto' added, else out/pareto"))]
CompareOut = Annotated[Optional[Path], typer.Option(help=_OUT("the study's 'output' with '_compare' added, else out/compare"))]
JourneyOut = Annotated[Optional[Path], typer.Option(help=_OUT("out/journey"))]
EveryCore = Annotated[Optional[int], typer.Option(help="Local worker processes (default: every core).")]
StepTimed = Annotated[Optional[int], typer.Option(help="Local worker processes (default: every core; step times then measured with every worker busy, --workers 1 for quiet-machine ones).")]
Dask = Annotated[Optional[str], typer.Option(help="Address of a running Dask scheduler (tcp://host:port).")]
RetryFailed = Annotated[bool, typer.Option(help="Compute failed cases again (infeasible ones stay).")]
NoProgress = Annotated[bool, typer.Option("--no-progress", help="No progress bar.")]
NoPlot = Annotated[bool, typer.Option("--no-plot", help="Skip the figures.")]
Format = Annotated[str, typer.Option("--format", help="Figure format: png, svg or pdf.")]
Dpi = Annotated[float, typer.Option(help="Figure resolution [dots per inch] (raster images).")]
DasTimeLimit = Annotated[Optional[float], typer.Option(help="Time limit of each MINLP search [s] (--das minlp; "
                                                        "default 60).", show_default=False)]
Force = Annotated[bool, typer.Option("--force", help="Run work estimated too big (over 2 h for one run, half the memory, a 10^6-point table) anyway.")]
Debug = Annotated[bool, typer.Option(help="Show tracebacks.")]
