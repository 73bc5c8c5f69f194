"""Eq. 4's terms measured in their physical limits (``objective_scale: limits``), by hand on the ore
train; and the heavy-haul command's own BLAS threads."""
import numpy as np
import pytest
from typer.testing import CliRunner

from ecostudy.cli import app
from ecostudy.api.blas import blas_threads, limit_blas_threads
from ecostudy.heavyhaul.linear import fence
from ecostudy.heavyhaul.rhc import Scales, objective_terms, objective_values
from ecostudy.io.loaders import load_consist

from .test_heavyhaul_study import PAPER, besides_adhesion, study


def test_each_term_in_its_limit_by_hand():
    """f = 10, weighted per real car: a virtual wagon of ten braking 1800 kN (each wagon at its
    180 kN) costs K_e K_b sum (180/180)^2 = 10 K_e K_b per second, as ten wagons of the full model;
    a virtual coupler at the 2000 kN limit spanning s real couplers costs K_f s; a car group 1 m/s
    off the reference on a 20 m/s line costs K_v (cars) (1/20)^2."""
    consist = load_consist(PAPER)
    reduction = fence(consist, 10, 20.0)
    largest = np.where(consist.pneumatic_brake > 0, consist.pneumatic_brake, 560e3)
    units = reduction.effort_scale(largest, consist.mass)
    assert units[0] == pytest.approx(560e3) and units[2] == pytest.approx(180e3)
    assert reduction.effort_scale(largest, consist.mass, "virtual")[2] == pytest.approx(1800e3)
    r = reduction.represented(consist.mass)
    terms = objective_terms(reduction.model, reduction.kinds, (10.0, 60.0, 10.0, 40.0), r,
                            Scales(2000.0, units / 1e3, 20.0))
    n = len(reduction.kinds)
    state = np.zeros(2 * n - 1)
    state[n + 5] = 2000.0 / terms.stiff[5]  # virtual coupler 5 at the limit
    state[3] = 1.0  # virtual car 3 1 m/s above v_r = 0
    moves = np.zeros((1, n))
    moves[0, 2] = -1800.0  # kN: virtual wagon 2, every wagon at its full brake
    wagons = np.array([k != "locomotive" for k in reduction.kinds])
    values = objective_values(terms, wagons, state[None, :], moves, np.zeros(2), 1.0)
    assert values["braking"] == pytest.approx(10.0 * 40.0 * 10, rel=1e-9)
    assert values["force"] == pytest.approx(10.0 * r.couplers[5], rel=1e-9)
    assert values["tracking"] == pytest.approx(60.0 * r.cars[3] / 400.0, rel=1e-9)
    assert values["energy"] == 0.0


def test_the_heavyhaul_command_runs_its_blas_single_threaded(tmp_path):
    """The command sets every loaded OpenBLAS to one thread before it computes (even a refused study)."""
    # numpy's wheel from PyPI (scripts/install.sh) ships OpenBLAS: without it the option would do nothing
    assert blas_threads(), "no OpenBLAS loaded: numpy was not installed from its PyPI wheel"
    limit_blas_threads(2)
    assert set(blas_threads().values()) == {2}
    result = CliRunner().invoke(app, ["heavyhaul", str(study(tmp_path, fence=[999])), "--no-progress"])
    assert result.exit_code == 2 and "fence" in result.output
    assert set(blas_threads().values()) == {1}


def test_the_braking_penalty_acts_once_the_terms_are_in_their_limits(tmp_path):
    """On the 5 km line, K_b 1 -> 60: in the paper's units the wagons' braking term stays a few
    hundredths of the force term (0.0005 -> 0.022 measured) and the wagons' braking moves little;
    with every term in its limit the braking term is comparable and the wagons' braking falls by
    more than half (250 -> 89 kWh) while the dynamic brakes take more."""
    import pandas as pd
    runs = {}
    for scale in ("paper", "limits"):
        out = tmp_path / scale
        # with every term in its limit tracking weighs less: a run arrived 103 s (21.7 %) late, which the
        # default arrival tolerance (5 % or 60 s) flags; this test is about the terms, so it allows 30 %
        file = study(tmp_path, objective_scale=scale, arrival_tolerance_percent=30)
        result = CliRunner().invoke(app, ["heavyhaul", str(file), "--out", str(out), "--no-progress", "--no-plot"])
        assert result.exit_code == 1, result.output  # flagged for adhesion only (the paper's plant)
        runs[scale] = pd.read_csv(out / "runs.csv").set_index("K_b")
        assert all(besides_adhesion(r) == [] for r in runs[scale]["reason"])  # every run stops within 1 m
    paper, limits = runs["paper"], runs["limits"]
    assert (paper["J_braking"] / paper["J_force"]).max() < 0.1
    assert limits.loc[60, "J_braking"] / limits.loc[60, "J_force"] > 0.2
    assert paper.loc[60, "wagon_brake_kWh"] > 0.8 * paper.loc[1, "wagon_brake_kWh"]
    assert limits.loc[60, "wagon_brake_kWh"] < 0.5 * limits.loc[1, "wagon_brake_kWh"]
    assert limits.loc[60, "dynamic_brake_kWh"] > 2 * limits.loc[1, "dynamic_brake_kWh"]
