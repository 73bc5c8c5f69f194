"""A controller that has no plan to drive falls back on its last plan, then on the eq. 6.8 reserve,
then brakes in full, and says so per step (steps.csv); a power limit that never binds is no row of
any formulation; the computation delay; the options of each controller kind."""
import dataclasses

import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.control.controllers import Convex, ForceReplay
from ecostudy.control.fallback import KINDS
from ecostudy.control.loop import check_delay, run_loop
from ecostudy.control.terminal import TerminalApproach
from ecostudy.core.errors import EcostudyWarning
from ecostudy.core.physics import Envelope, power_never_binds
from ecostudy.core.plant import Plant, Truth
from ecostudy.core.types import State
from ecostudy.io.writers import write_csv
from ecostudy.ocp.convex import ConvexProgram, ConvexWeights, trapezoid_grid
from ecostudy.ocp.problem import prepare
from ecostudy.studies.loopsteps import step_columns, step_counts, steps_frame

from .conftest import TRACKS, TRAINS, write_yaml
from .test_convex import advanced, commuter  # noqa: F401 (fixtures: the thesis train on the advanced trip)

runner = CliRunner()


class CappedAt:
    """The convex controller with Clarabel's iteration cap set to 1 (a real solver setting, the
    solve then ends 'MaxIterations', unusable) at the chosen samples and left at its default else."""

    def __init__(self, inner, samples):
        self.inner, self.samples = inner, set(samples)

    @property
    def solve_seconds(self):
        return self.inner.solve_seconds

    def plan(self, measured):
        self.inner.max_iter = 1 if len(self.inner.step_log) in self.samples else None
        return self.inner.plan(measured)


@pytest.mark.slow
def test_an_unusable_solve_mid_trip_applies_the_shifted_plan_and_steps_csv_says_so(commuter, advanced, tmp_path):
    _, segment = advanced
    controller = Convex(ConvexProgram(segment, commuter, trapezoid_grid(segment, 200), ConvexWeights()),
                        (0.0, 200.0), hold=0.1)
    capped = [0, 300, 301, 302]  # at the stand there is no plan yet; mid-trip there is
    result = run_loop(Plant(segment, commuter), CappedAt(controller, capped), 0.1, plant_step=0.1)
    write_csv(tmp_path / "steps.csv", steps_frame(step_columns(result, controller)))
    steps = pd.read_csv(tmp_path / "steps.csv")
    assert list(steps.loc[capped, "status"]) == ["MaxIterations"] * 4
    assert steps.loc[0, "fallback"] == "full_brake" and steps.loc[0, "handle"] == -1.0
    assert list(steps.loc[capped[1:], "fallback"]) == ["shifted_plan"] * 3
    assert (steps.loc[capped[1:], "handle"] > -1.0).all()  # no full braking mid-trip
    assert steps.loc[capped[1:], "speed_mps"].min() > 5.0  # mid-trip indeed
    counts = step_counts(controller)
    assert all((steps["fallback"] == kind).sum() == counts[f"fallback_{kind}_count"] for kind in KINDS)
    assert counts["fallback_full_brake_count"] == 1  # at the stand only (a braking plan leaning on the
    # relaxation near the stop of this coarse grid goes to the eq. 6.8 reserve, not a full brake)
    assert abs(result.stop_error_m) < 0.5 and result.overspeed_max_kmh == 0.0


def test_the_pointwise_power_test():
    speeds = [0.0, 10.0, 20.0]
    assert power_never_binds(1e6, 2e7, speeds) and not power_never_binds(1e6, 1.9e7, speeds)
    # pointwise on a falling force limit: its peak times the top speed would say it binds
    assert power_never_binds([1e6, 9e5, 4e5], 9e6, speeds)
    assert not power_never_binds([1e6, 9.5e5, 4e5], 9e6, speeds)


def test_a_power_limit_that_never_binds_is_no_row_of_the_socp_or_the_nlp(commuter, advanced):
    track, segment = advanced
    force = Envelope("force_power", max_force=1e6)
    lean = dataclasses.replace(commuter, traction=force)
    huge = dataclasses.replace(commuter, traction=Envelope("force_power", max_force=1e6, max_power=1e9))  # 1e6 kW
    nodes = trapezoid_grid(segment, 100)
    with pytest.warns(EcostudyWarning, match="traction power limit never binds: dropped"):
        program = ConvexProgram(segment, huge, nodes, ConvexWeights())
    assert program.idle_power == ("traction",) and program.train.traction == force
    problem = (nodes, State(), (0.0, 200.0), 0.0, 1.0, None)
    assert program.assemble(*problem)[0].shape == ConvexProgram(segment, lean, nodes).assemble(*problem)[0].shape
    plan = program.solve(State(), (0.0, 200.0))
    assert plan.usable and plan.gap <= 1e-6
    with pytest.warns(EcostudyWarning, match="power limit never binds: dropped"):
        case = prepare(track, huge, "A", "B", 100)
    assert case.idle_power == ("traction",) and case.train.traction == force
    binding = dataclasses.replace(commuter, traction=Envelope("force_power", max_force=1e6, max_power=1e7))
    assert ConvexProgram(segment, binding, nodes).idle_power == ()  # 10 MW binds above 10 m/s: kept


def test_the_computation_delay_holds_the_previous_control_and_is_repeatable(commuter, advanced):
    _, segment = advanced

    def trip(delay):
        controller = Convex(ConvexProgram(segment, commuter, trapezoid_grid(segment, 120), ConvexWeights()),
                            (0.0, 200.0), hold=0.5)
        return run_loop(Plant(segment, commuter), controller, 0.5, plant_step=0.5, delay=delay)

    now, late, again = trip(0), trip(1), trip(1)
    assert now.handles[0] == pytest.approx(1.0, abs=1e-6) and late.handles[0] == 0.0  # none planned yet: coast
    assert late.handles == again.handles and late.arrival_time_s == again.arrival_time_s
    assert abs(late.stop_error_m) < 0.5 and late.overspeed_max_kmh == 0.0
    assert abs(late.arrival_time_s - now.arrival_time_s) < 2.0


def _study(tmp_path, controller):
    path = tmp_path / "s.yaml"
    write_yaml(path, {"name": "s", "track": str(TRACKS / "yazhemsky2017_advanced_1km.yaml"),
                      "train": str(TRAINS / "yazhemsky2017_commuter.yaml"), "window_s": [0, 200], "points": 60,
                      "sample_time_s": 0.5, "controllers": [controller]})
    return path


@pytest.mark.parametrize("controller, field", [
    ({"name": "a", "kind": "ato", "estimator": True}, "estimator"),
    ({"name": "c", "kind": "convex", "rspc": {"horizon": 2}}, "rspc"),
    ({"name": "c", "kind": "convex", "block": 5}, "block"),
    ({"name": "c", "kind": "convex", "variant": "two_step"}, "variant"),
    ({"name": "c", "kind": "convex", "omega": 10.0}, "omega"),
    ({"name": "s", "kind": "sbpc", "time_budget_s": 0.1}, "time_budget_s")])
def test_an_option_the_controller_kind_does_not_use_is_refused_in_one_line(tmp_path, controller, field):
    path = _study(tmp_path, controller)
    result = runner.invoke(app, ["simulate", str(path), "--no-progress"])
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert str(path.name) in lines[0] and field in lines[0] and "not used by a controller of kind" in lines[0]


@pytest.mark.slow
def test_a_study_writes_steps_per_run_and_counts_fallbacks(tmp_path):
    path = _study(tmp_path, {"name": "c", "kind": "convex", "compute_delay": 1})
    out = tmp_path / "out"
    result = runner.invoke(app, ["simulate", str(path), "--out", str(out), "--no-progress", "--no-plot"])
    assert result.exit_code in (0, 1), result.output
    steps = pd.read_csv(out / "steps" / "c_draw0.csv")
    assert {"sample", "position_m", "speed_mps", "handle", "status", "solve_ms", "gap", "fallback", "softened",
            "mass_estimate"} <= set(steps.columns)
    runs = pd.read_csv(out / "runs.csv")
    assert len(steps) > 100 and runs.loc[0, "compute_delay_samples"] == 1 and steps["sample"].is_monotonic_increasing
    assert runs.loc[0, "fallback_full_brake_count"] == (steps["fallback"] == "full_brake").sum()
    assert steps.loc[0, "handle"] == 0.0  # one sample of computation delay: the train waits a sample


def test_a_terminal_approach_with_a_braking_reserve_stops_a_replayed_plan_on_the_mark(commuter, advanced):
    """The stop of SBPC and SPPC (control/terminal.py): the convex plan from the stand replayed
    open loop on a heavier train with weaker brakes overruns; with the terminal approach (full
    braking on the stopping curve of 80 % of the model's brake, coasting otherwise) it stops
    within 1 m, on the DAS levels -1 and 0 only once engaged."""
    track, segment = advanced
    case = prepare(track, commuter, "A", "B", 200)
    plan = ConvexProgram(segment, commuter, trapezoid_grid(segment, 200), ConvexWeights()).solve(State(), (0.0, 200.0))
    plant = Plant(segment, commuter, Truth(mass=1.1, braking=0.9))
    blind = run_loop(plant, ForceReplay(commuter, plan.nodes, plan.force), 0.38, plant_step=0.38)
    approach = TerminalApproach(ForceReplay(commuter, plan.nodes, plan.force), case, 0.38, reserve=0.2)
    seeing = run_loop(plant, approach, 0.38, plant_step=0.38)
    assert blind.stop_error_m > 1.0 and abs(seeing.stop_error_m) <= 1.0 and approach.engaged > 0
    assert set(seeing.handles[-approach.engaged:]) <= {-1.0, 0.0}


def test_the_computation_delay_is_samples_or_measured():
    assert check_delay(0) == 0 and check_delay(2) == 2 and check_delay("measured") == "measured"
    for bad in (-1, 0.5, True, "later"):
        with pytest.raises(ValueError, match="number of samples >= 0 or 'measured'"):
            check_delay(bad)


class WithoutTimeLimit(ConvexProgram):
    """The convex program with no time limit on Clarabel (a real solver setting, Clarabel's default):
    every solve runs to its end, so that a plan can finish usable yet later than the controller's budget."""

    def limit(self, max_iter=None, seconds=None):
        super().limit(max_iter, None)


def test_a_convex_plan_over_its_time_budget_is_not_driven_and_counts_as_a_failure(commuter, advanced):
    """A plan that finished usable but after ``time_budget_s`` (here 1 ns) is refused: the fallback
    drives the sample and ``failures`` counts it, as it counts an unusable solve."""
    _, segment = advanced
    controller = Convex(WithoutTimeLimit(segment, commuter, trapezoid_grid(segment, 120), ConvexWeights()),
                        (0.0, 200.0), hold=0.5, budget=1e-9)
    handle = controller.plan(State())
    assert controller.step_log[-1].status == "over_budget", controller.step_log[-1]
    assert controller.gaps and controller.failures == 1  # the plan was usable, and not driven
    assert handle == -1.0  # at the stand, with no earlier plan: the fallback brakes in full
