"""Controller kinds are registered: the guide's new kind (docs/closed_loop.md, "Adding a controller
kind"), run as written, is accepted by a study file and driven, scored and tabled like the others;
an unknown kind and an option the kind does not read are refused in one line."""
import re
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.control.controllers import Quantised
from ecostudy.control.loop import run_loop
from ecostudy.core.errors import EcostudyError
from ecostudy.core.grid import make_segment
from ecostudy.core.plant import Plant
from ecostudy.io.loaders import load_track, load_train
from ecostudy.io.loopfile import CONTROLLER_KINDS

from .conftest import TRACKS, TRAINS
from .test_simulate import study

GUIDE = Path(__file__).resolve().parent.parent / "docs" / "closed_loop.md"


@pytest.fixture
def guide_kind():
    block = next(b for b in re.findall(r"```python\n(.*?)```", GUIDE.read_text(), re.S)
                 if "CONTROLLER_KINDS.register" in b)
    exec(block, {})
    yield "coast_then_brake"
    CONTROLLER_KINDS._specs.pop("coast_then_brake", None)


def test_the_guide_s_new_kind_runs_in_a_study(tmp_path, guide_kind):
    path = study(tmp_path, controllers=[{"name": "rule", "kind": guide_kind, "compute_delay": 0}], deviations={})
    out = tmp_path / "out"
    r = CliRunner().invoke(app, ["simulate", str(path), "--out", str(out), "--no-progress", "--no-plot"])
    assert r.exit_code in (0, 1), r.output
    runs = pd.read_csv(out / "runs.csv")
    assert list(runs["controller"]) == ["rule", "rule"]
    assert runs["status"].isin(["ok", "flagged"]).all() and (runs["traction_energy_kWh"] > 0).all()
    assert (runs["stop_error_m"].abs() < 10).all()  # it brakes for the stop (a rule of thumb, not to 1 m)
    assert (runs["overspeed_max_kmh"] < 0.5).all()
    assert (r.exit_code == 0) == (runs["status"] == "ok").all()


def test_unknown_kinds_and_foreign_options_are_refused(tmp_path, guide_kind):
    for controller, words in (({"name": "x", "kind": "nope"}, ["unknown controller kind 'nope'", "convex"]),
                              ({"name": "x", "kind": guide_kind, "block": 3}, ["block", "not used by"])):
        r = CliRunner().invoke(app, ["simulate", str(study(tmp_path, controllers=[controller])),
                                     "--out", str(tmp_path / "o"), "--no-progress"])
        lines = [line for line in r.output.splitlines() if line.startswith("error:")]
        assert r.exit_code == 2 and len(lines) == 1 and all(w in lines[0] for w in words), r.output


class _Doubled:
    """A controller with a bug: twice the full handle until the last 300 m, then full braking."""

    def __init__(self, segment):
        self.distance, self.solve_seconds = segment.distance, []

    def plan(self, state):
        self.solve_seconds.append(0.0)
        return 2.0 if state.position < self.distance - 300 else -1.0


def test_a_handle_outside_minus_one_to_one_fails_the_run_naming_it(tmp_path):
    """A controller's handle is in [-1, 1]: one of 2 would drive twice the traction envelope, so the
    run fails with the handle, where it was planned and the controller, rather than drive it."""
    CONTROLLER_KINDS.register("doubled", lambda build: _Doubled(build.segment))
    try:
        path = study(tmp_path, controllers=[{"name": "bug", "kind": "doubled", "compute_delay": 0}], deviations={},
                     draws=1)
        r = CliRunner().invoke(app, ["simulate", str(path), "--out", str(tmp_path / "out"), "--no-progress",
                                     "--no-plot", "--workers", "1"])
    finally:
        CONTROLLER_KINDS._specs.pop("doubled", None)
    runs = pd.read_csv(tmp_path / "out" / "runs.csv")
    assert r.exit_code == 1 and list(runs["status"]) == ["failed"], r.output
    assert "_Doubled.plan gave the handle 2 at 0.0 m, 0.00 m/s, clock 0.0 s: a handle is a number in [-1, 1]" \
        in runs["reason"].iloc[0]


def test_a_driver_advisory_loop_refuses_its_inner_controllers_handle_outside_minus_one_to_one():
    """Quantised (a DAS loop) snaps a handle to the nearest level: a bug's handle of 2 would be
    driven as full traction; it is refused as the loop refuses any controller's."""
    train = load_train(TRAINS / "yazhemsky2017_commuter.yaml")
    segment = make_segment(load_track(TRACKS / "yazhemsky2017_advanced_1km.yaml"), train, "A", "B")
    loop = Quantised(_Doubled(segment), [-1.0, 0.0, 0.5, 0.75, 1.0])
    with pytest.raises(EcostudyError, match="_Doubled.plan gave the handle 2 at 0.0 m"):
        run_loop(Plant(segment, train), loop, 0.5)
