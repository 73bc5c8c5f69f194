"""A published train and track (TTOBench's VIRM6 intercity on its 48.5 km 140 / 100 / 140 km/h
line, ``tests/data/ttobench``, unmodified) read by ecostudy and solved, against the optimum the
files' authors' own solver finds for them: ms-eetc's ``casadiSolver`` (RK4, 1000 intervals, CasADi's
Ipopt), 1541 s from 1 m/s to 1 m/s, the net energy minimised, measured by ``bench/bench_mseetc.py``
(ms-eetc d7aadf2). Nothing typed in: the train's pneumatic brake, efficiencies, rotating mass and
Davis terms are what ecostudy's reader makes of the file."""
from bench.bench_gpops import run
from ecostudy.io.loaders import load_track, load_train

from .conftest import DATA

MSEETC_KWH = 370.0841  # `python bench/bench_mseetc.py --ttobench T --mseetc M --points 1000 --pneumatic on`
AGREE = 1e-4  # relative: two transcriptions of the same problem at K = 1000 (measured 2.5e-5 apart)


def test_ttobench_virm6_solves_to_ms_eetcs_optimum_of_the_same_files():
    track = load_track(DATA / "ttobench" / "00_var_speed_limit_100.json")
    train = load_train(DATA / "ttobench" / "NL_Intercity_VIRM6.json")
    assert train.braking.kind == "table"  # regenerative force-power plus the pneumatic brake, as ms-eetc adds them
    r = run(track, train, 1000, v_end=1.0, running_time=1541.0)
    assert r["ipopt"] == "optimal", r
    assert abs(r["model_kWh"] / MSEETC_KWH - 1) < AGREE, r
    assert abs(r["simulated_kWh"] / MSEETC_KWH - 1) < AGREE, r  # re-driven by the plant from 1 m/s
    assert abs(r["simulated_time_s"] - 1541.0) < 0.5 and abs(r["simulated_end_speed"] - 1.0) < 0.1, r
