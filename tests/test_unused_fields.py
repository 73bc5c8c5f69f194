"""A study file's fields that a command reads but does not use are named in a warning: `solve`,
`compare` and `pareto` run the study's base case, `run` runs all of it. The warning comes as the
study is read, before any work: `compare` and `pareto` are stopped right after it by an output
folder that is a file (their runs cost seconds and say nothing more about the warning)."""
import warnings

import pytest
from typer.testing import CliRunner

from ecostudy import api
from ecostudy.cli import app
from ecostudy.core.errors import EcostudyWarning, InputError
from ecostudy.studies.cases import expand

from .conftest import TRACKS, TRAINS, write_yaml


def study(tmp_path, **fields):
    return write_yaml(tmp_path / "study.yaml", {
        "name": "unused", "track": str(TRACKS / "amsterdam_rokin_centraal.yaml"),
        "train": str(TRAINS / "amsterdam_metro.yaml"), "running_time_s": 76, "points": 200,
        "output": str(tmp_path / "out"), **fields})


def unused_warnings(call):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        call()
    return [str(w.message) for w in caught if issubclass(w.category, EcostudyWarning) and "not used by" in str(w.message)]


def test_solve_names_the_driver_advice_and_scenarios_it_does_not_run(tmp_path):
    path = study(tmp_path, das="round", scenarios=[{"name": "slower", "running_time_s": 90}])
    said = unused_warnings(lambda: api.solve_folder(path, plot=False, out=tmp_path / "solve"))
    assert len(said) == 1, said
    assert "das, scenarios" in said[0] and "`ecostudy solve`" in said[0] and "study.yaml" in said[0], said


def refused(command, path, tmp_path, **options):
    """``command`` on ``path`` into an output folder that is a file: refused after reading the study."""
    afile = tmp_path / "afile"
    afile.write_text("x")

    def call():
        with pytest.raises(InputError, match="afile"):
            command(path, plot=False, workers=1, out=afile, **options)
    return call


def test_compare_names_an_objective_it_does_not_use(tmp_path):
    path = study(tmp_path, objective="net_energy")
    said = unused_warnings(refused(api.compare_folder, path, tmp_path))
    assert len(said) == 1 and "objective" in said[0] and "`ecostudy compare`" in said[0], said


def test_pareto_names_the_study_s_advice_and_a_plain_study_nothing(tmp_path):
    path = study(tmp_path, das="phases")
    said = unused_warnings(refused(api.pareto_folder, path, tmp_path, count=2))
    assert len(said) == 1 and "das" in said[0] and "`ecostudy pareto`" in said[0], said
    plain = study(tmp_path, objective="energy")  # without das; the objective compare and the front use anyway
    assert unused_warnings(refused(api.compare_folder, plain, tmp_path)) == []
    assert unused_warnings(lambda: api.solve_folder(plain, plot=False, out=tmp_path / "plain")) == []


def test_weights_the_objective_does_not_use_are_named_by_solve_and_run(tmp_path):
    """A study's weights, given as their defaults, with objective energy: solve and run ignored them
    without a word (run warned only of weights other than the defaults), as an unused das is named."""
    path = study(tmp_path, weights={"time": 1, "energy": 1}, points=50)
    with pytest.warns(EcostudyWarning, match=f"^{path}: weights: read but not used: the objective is energy, not mixed$"):
        api.solve_folder(path, plot=False, out=tmp_path / "solve")
    with pytest.warns(EcostudyWarning, match=f"^{path}: weights: read but not used: no case has objective mixed$"):
        expand(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the objective mixed uses them: no warning
        api.solve_folder(path, objective="mixed", window="70,100", plot=False, out=tmp_path / "mixed")
