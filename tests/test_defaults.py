"""The grid-size defaults are named once (``core.defaults``): the study schemas, the API and the
command line all default to those constants, and a command given no K solves at that K."""
import inspect
import json

import typer

from ecostudy import api
from ecostudy.analysis.single import solve_run
from ecostudy.api import fronts, single
from ecostudy.calibration.savings import savings
from ecostudy.cli import app
from ecostudy.core.defaults import FRONT_POINTS, RUN_POINTS
from ecostudy.io import loaders, schemas
from ecostudy.network.fleet import plan
from ecostudy.studies.compare import compare_cases
from ecostudy.studies.journey import journey
from ecostudy.studies.pareto import sweep, weighted_points

from .conftest import TRACKS, TRAINS


def default(function, name="points"):
    return inspect.signature(function).parameters[name].default


def option(command, name="points"):
    command = typer.main.get_command(app).commands[command]
    return next(p for p in command.params if p.name == name)


def test_the_study_schemas_default_to_the_constants():
    assert schemas.StudyFile.model_fields["points"].default == RUN_POINTS
    assert loaders.Study.__dataclass_fields__["points"].default == RUN_POINTS
    assert schemas.NetworkStudyFile.model_fields["points"].default == FRONT_POINTS


def test_the_api_and_the_library_default_to_the_constants():
    assert [default(f) for f in (api.solve, solve_run, compare_cases)] == [RUN_POINTS] * 3
    assert [default(f) for f in (api.pareto, api.replanner, fronts.journey_folder, sweep, weighted_points,
                                 journey, plan, savings)] == [FRONT_POINTS] * 8
    # None: the study file's K, else the constant (below)
    assert default(single.solve_folder) is None and default(fronts.pareto_folder) is None


def test_the_command_line_defaults_to_the_constants():
    assert option("journey").default == FRONT_POINTS
    for command in ("solve", "pareto", "compare"):
        points = option(command)
        assert points.default is None, command
        assert f"{RUN_POINTS}; {FRONT_POINTS} for a front" in points.help, command


def test_a_solve_given_no_points_solves_at_the_run_default(tmp_path):
    report = api.solve_folder(track=TRACKS / "amsterdam_rokin_centraal.yaml", train=TRAINS / "amsterdam_metro.yaml",
                              time=76.0, out=tmp_path, plot=False)
    assert report.status.ok, report.text
    assert json.loads((tmp_path / "inputs.json").read_text())["points"] == RUN_POINTS
    assert json.loads((tmp_path / "summary.json").read_text())["points"] == RUN_POINTS
