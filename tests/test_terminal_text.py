"""What a user reads in the terminal: a number that rounds to zero prints as zero ('0.000', never
'-0.000') in every printed table and report line, while the files keep the value; and what Click
checks itself (an option's type or range, an unknown option or command, a missing argument) is
refused as ecostudy refuses a bad option: one line naming the option, exit status 2, no usage box."""
import json
import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy.api import validate_folder
from ecostudy.api.outcome import shown
from ecostudy.api.single import run_lines
from ecostudy.calibration.generate import LogNoise, generate_log
from ecostudy.cli import app
from ecostudy.core.units import number, signed
from ecostudy.io.loaders import load_track, load_train
from ecostudy.io.logfile import write_log
from ecostudy.report.html import numeric_cell

from .conftest import ROOT, TRACKS, TRAINS, write_yaml

NEGATIVE_ZERO = re.compile(r"(?<![\w/.-])-0(\.0+)?(?![0-9.])")  # '-0', '-0.000'; not '-0.001', 'pytest-0/'


def test_a_value_that_rounds_to_zero_prints_as_zero_with_its_digits():
    assert [number(-1e-9, s) for s in (".3f", "9.3f", "+.2f", ".1%")] == ["0.000", "    0.000", "+0.00", "0.0%"]
    assert number(-0.0, ".4g") == "0" and number(-0.0004) == "0.000"
    # what does not round to zero keeps its sign; not a number stays as it is
    assert [number(-0.0006), number(-1e-9, ".4g"), number(float("-inf")), number(-3, "d")] == \
        ["-0.001", "-1e-09", "-inf", "-3"]


@pytest.mark.parametrize("places, values", [(".3f", [-7.85444e-17, -1.5e-14, -0.0004, -0.0]),
                                             (".4g", [-0.0, 0.0]), (".5g", [-0.0, 1.0])])
def test_every_printed_table_shows_a_rounded_zero_as_zero(places, values):
    """Every command's table is printed by ``api.outcome.shown`` (pareto, compare, journey, network at
    .3f; simulate, heavyhaul, validate at .4g; calibrate at .5g, where only -0 itself rounds to zero)."""
    text = shown(pd.DataFrame({"unserved_kWh": values, "saving_pct": [4.002] * len(values)}), places=places)
    assert not NEGATIVE_ZERO.search(text), text


def test_report_html_shows_a_rounded_zero_as_zero_by_the_same_formatter():
    assert [numeric_cell(x, 3) for x in (-1e-9, -0.0006)] == ['<td class="n" data-v="-1e-09">0.000</td>',
                                                             '<td class="n" data-v="-0.0006">-0.001</td>']
    assert numeric_cell(-12345.678, 2) == '<td class="n" data-v="-12345.678">-12\u2009345.68</td>'


def test_a_table_prints_each_column_to_its_own_digits():
    """simulate's, heavy-haul's and validate's tables give each number column its format: no
    '-2.789e-06' m of a stop error beside '0.5812', no '84' beside '84.06' s."""
    frame = pd.DataFrame({"controller": ["a", "b"], "arrival_mean_s": [84.0, 84.06],
                          "stop_error_min_m": [-2.789e-06, 0.5812], "solve_p95_max_ms": [294.0, 284.8]})
    text = shown(frame, {"controller": None, "arrival_mean_s": ".2f", "stop_error_min_m": ".3f",
                         "solve_p95_max_ms": None}, ".4g")
    assert [line.split() for line in text.splitlines()[1:]] == [["a", "84.00", "0.000", "294"],
                                                                 ["b", "84.06", "0.581", "284.8"]], text


def test_a_network_table_prints_a_balance_that_rounds_to_zero_as_zero(tmp_path):
    """Two metro trains on one substation, the independent runs: the energy balance closes to
    about 1e-14 % (measured -1.5e-14, printed '-0.000' before), the substation's file keeps it."""
    study = write_yaml(tmp_path / "net.yaml", {
        "name": "tiny", "track": str(TRACKS / "metro_line_4stops.yaml"), "train": str(TRAINS / "amsterdam_metro.yaml"),
        "stops": ["Noord", "Station"], "running_times_s": [56.0], "time_step_s": 1.0,
        "trains": [{"name": "A", "offset_s": 0}, {"name": "B", "offset_s": 45}],
        "substation": {"position_m": 300}, "strategies": ["independent"], "points": 300,
        "output": str(tmp_path / "out")})
    r = CliRunner().invoke(app, ["network", str(study), "--workers", "1", "--no-plot"])
    assert r.exit_code == 0, r.output
    table = r.stdout.split("\n1 strategy")[0]
    assert "balance_error_pct" in table and not NEGATIVE_ZERO.search(table), table
    stored = json.loads((tmp_path / "out" / "network.json").read_text())
    kept = [v for v in _values(stored, "balance_error_pct")]
    assert kept and all(abs(v) < 1e-9 for v in kept)  # the file keeps the value, printed as 0.000


def test_a_case_not_ok_shows_its_status_kind_in_the_table_and_its_reason_once_under_it(tmp_path):
    """Two trains 45 s apart, 500 m of buffer: independent driving comes within 195 m (flagged) and
    following cannot depart (failed). The printed table's status column holds the kind alone, so a
    long reason does not widen every row; each reason is printed once, under the table."""
    study = write_yaml(tmp_path / "net.yaml", {
        "name": "tiny", "track": str(TRACKS / "metro_line_4stops.yaml"), "train": str(TRAINS / "amsterdam_metro.yaml"),
        "stops": ["Noord", "Station"], "running_times_s": [56.0], "time_step_s": 1.0,
        "trains": [{"name": "A", "offset_s": 0}, {"name": "B", "offset_s": 45}], "buffer_m": 500,
        "substation": {"position_m": 300}, "strategies": ["independent", "following"], "points": 300,
        "output": str(tmp_path / "out")})
    r = CliRunner().invoke(app, ["network", str(study), "--workers", "1", "--no-plot"])
    assert r.exit_code == 1, r.output
    rows = {line.split()[0]: line.split()[1] for line in r.stdout.split("\n2 strategies")[0].splitlines()[1:]
            if line.split()[1:2] and line.split()[1] in ("ok", "flagged", "failed")}  # not the notes under the table
    assert rows == {"independent": "flagged", "following": "failed"}, r.stdout
    assert "buffer_m" not in r.stdout
    assert r.stderr.count("cannot keep buffer_m 500 m") == 1 and r.stderr.count("closer than buffer_m 500 m") == 1, r.stderr
    stored = pd.read_csv(tmp_path / "out" / "network_substation.csv").set_index("strategy")["status"]
    assert stored["following"].startswith("failed: train B, leg 1: cannot keep buffer_m 500 m")  # the file keeps it


def _values(tree, key):
    if isinstance(tree, dict):
        for k, v in tree.items():
            yield from ([v] if k == key else _values(v, key))
    elif isinstance(tree, list):
        for v in tree:
            yield from _values(v, key)


def test_a_solve_report_prints_energies_that_round_to_zero_as_zero(amsterdam_76s, tmp_path):
    """solve's report (``api.single.run_lines``) of a real run whose net and regenerated energy are
    set to -1e-9 kWh (a run without regeneration sums its braking power to about that), and its
    re-simulated energy error to -1e-9 % (the verification line, `io.runsummary.Verification.errors`)."""
    s = amsterdam_76s.summary
    run = replace(amsterdam_76s, summary={**s, "net_energy_kWh": -1e-9, "regenerated_energy_kWh": -1e-9,
                                          "verification": {**s["verification"], "energy_error_pct": -1e-9}})
    text = "\n".join(run_lines(run, tmp_path))
    assert "net energy            0.000 kWh  (regenerated 0.000 kWh)" in text, text
    assert "energy +0.000 %" in text and not NEGATIVE_ZERO.search(text), text
    assert repr(run).split("; ")[0].endswith("net 0.000 kWh"), repr(run)  # its line in Python


def test_a_validated_log_that_the_model_replays_prints_its_difference_as_zero(tmp_path):
    """A noise-free log of the train file's own model: validate's traction difference is -0.00015 %,
    printed in its line as '+0.00 %' and in its table as '0.00' ('-0.00 %' and '-0.0001541' before)."""
    track_file, train_file = TRACKS / "calibration_line.yaml", TRAINS / "regional_alstom.yaml"
    train = load_train(train_file)
    frame, _ = generate_log(load_track(track_file), train, ["West", "Middle"], train, seed=0,
                            noise=LogNoise(speed=0.0, power=0.0))
    write_log(tmp_path / "log.csv", {"track": str(track_file), "train": str(train_file)}, frame)
    report = validate_folder(tmp_path / "log.csv", out=tmp_path / "val", plot=False)
    stored = pd.read_csv(tmp_path / "val" / "validate.csv")["traction_difference_pct"]
    assert abs(stored.iloc[0]) < 0.01  # the file keeps the value
    line = next(x for x in report.text.splitlines() if x.startswith("traction energy:"))
    assert line.endswith("(+0.00 %)") and not NEGATIVE_ZERO.search(report.text), report.text
    header, row = report.text.splitlines()[:2]
    assert dict(zip(header.split(), row.split()))["traction_difference_pct"] == "0.00", report.text


def test_a_signed_number_shows_its_sign_and_a_rounded_zero_as_plus_zero():
    assert [signed(-1e-9), signed(-0.0), signed(0.0), signed(-0.0006), signed(0.12, 2), signed(-0.3, 0)] == \
        ["+0.000", "+0.000", "+0.000", "-0.001", "+0.12", "+0"]


def _validated_noise_free(tmp_path, **tolerances):
    track_file, train_file = TRACKS / "calibration_line.yaml", TRAINS / "regional_alstom.yaml"
    train = load_train(train_file)
    frame, _ = generate_log(load_track(track_file), train, ["West", "Middle"], train, seed=0,
                            noise=LogNoise(speed=0.0, power=0.0))
    write_log(tmp_path / "log.csv", {"track": str(track_file), "train": str(train_file)}, frame)
    return validate_folder(tmp_path / "log.csv", out=tmp_path / "val", plot=False, **tolerances)


def test_a_flag_reason_prints_a_signed_difference_that_rounds_to_zero_as_plus_zero(tmp_path):
    """Validate's reason for a run flagged at zero tolerance: the traction difference -0.00015 % is
    '+0.0 % off the log' ('-0.0 %' before, an f-string's own '+.1f' beside the formatter)."""
    report = _validated_noise_free(tmp_path, energy_tolerance=0.0)
    printed = "\n".join(report.problems())  # what the command line prints below its table
    assert "traction energy +0.0 % off the log" in printed and not NEGATIVE_ZERO.search(printed), printed


def test_a_refused_log_prints_a_position_step_that_rounds_to_zero_as_plus_zero(tmp_path):
    """A 1 Hz log at 25 m/s whose position stands still for one row (it steps back 0.3 m, the
    speeds give 25 m): the refusal names a jump of '+0 m' ('-0 m' before)."""
    x = [300.0 + 25.0 * i for i in range(40)]
    x[20:] = [p - 25.3 for p in x[20:]]
    rows = "".join(f"{i:.1f},{x[i]:.3f},25.00,10\n" for i in range(40))
    path = tmp_path / "frozen.csv"
    path.write_text(f"---\ntrack: {TRACKS / 'calibration_line.yaml'}\ntrain: {TRAINS / 'regional_alstom.yaml'}\n---\n"
                    "time_s,position_m,speed_mps,force_kN\n" + rows)
    r = CliRunner().invoke(app, ["validate", str(path), "--out", str(tmp_path / "o"), "--no-plot"])
    assert r.exit_code == 2 and "row 21: the position jumps by +0 m in 1 s" in r.output, r.output
    assert not NEGATIVE_ZERO.search(r.output), r.output


# ------------------------------------------------------------------- Click's own refusals, as one line
@pytest.mark.parametrize("args, fragment", [
    (["solve", "--points", "abc"], "command line: --points: input should be a valid integer"),
    (["check", "out", "--time", "x"], "command line: --time: input should be a valid number"),
    (["pareto", "--count", "x"], "command line: --count: input should be a valid integer"),
    (["solve", "--objective", "fast"], "command line: --objective: 'fast' is not one of 'energy'"),
    (["heavyhaul", "h.yaml", "--blas-threads", "0"], "command line: --blas-threads: input should be greater than or "
                                                     "equal to 1"),
    (["calibrate", "x.csv", "--bootstrap", "-1"], "command line: --bootstrap: input should be greater than or equal to 0"),
    (["validate", "x.csv", "--energy-tolerance", "-1"], "command line: --energy-tolerance: input should be greater"),
    (["network", "n.yaml", "--workers", "two"], "command line: --workers: input should be a valid integer"),
    (["journey", "--supplement", "10"], "command line: --train: missing"),
    (["run"], "command line: STUDY: missing"),
    (["solve", "--bogus"], "command line: --bogus: no such option"),
    (["solve", "--das"], "command line: --das: requires an argument"),
    (["simulate"], "command line: STUDY: missing"),
    (["ecostudy-solve"], "command line: no such command 'ecostudy-solve'"),
])
def test_clicks_own_refusals_read_as_ecostudys(args, fragment):
    r = CliRunner().invoke(app, args)
    assert r.exit_code == 2 and r.stdout == "", r.output
    assert r.stderr.splitlines() == [f"error: {r.stderr.split('error: ', 1)[1].strip()}"], r.stderr
    assert fragment in r.stderr and "Usage:" not in r.output and "Traceback" not in r.output, r.stderr


def test_ecostudys_own_refusal_reads_the_same(tmp_path):
    """The same shape as ecostudy's own range check of an option (``studies.options.check_options``)."""
    r = CliRunner().invoke(app, ["network", str(ROOT / "studies" / "network_metro_2trains.yaml"), "--workers", "0",
                                 "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and r.stderr == "error: command line: --workers: must be at least 1 and at most 256, not 0\n"


def test_the_installed_command_refuses_in_one_line_and_still_helps(tmp_path):
    """The ``ecostudy`` executable (``cli.app.main``): one line and exit 2; no arguments: the help (exit
    2, as Click's no_args_is_help); --help: the help, exit 0."""
    exe = str(Path(sys.executable).parent / "ecostudy")
    bad = subprocess.run([exe, "solve", "--points", "1.5"], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert (bad.returncode, bad.stdout) == (2, "") and bad.stderr.startswith("error: command line: --points: "), bad
    assert len(bad.stderr.splitlines()) == 1, bad.stderr
    bare = subprocess.run([exe], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert bare.returncode == 2 and "Commands:" in bare.stdout + bare.stderr and "error:" not in bare.stderr
    helped = subprocess.run([exe, "solve", "--help"], capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert helped.returncode == 0 and "--points" in helped.stdout


def test_report_html_keeps_four_digits_of_each_parameter_in_a_column_of_mixed_units():
    """calibrate's parameter table holds a mass [kg] beside an efficiency in one column: one precision
    for the column (from its median) showed the fitted efficiency 0.8537 as 0.9, its prior 0.88 as
    0.9 and its standard error 0.000213 as 0.00. Each value keeps four significant digits (solver
    noise, below a millionth and a millionth of the column's largest, still rounds to the column's places)."""
    from ecostudy.report.html import data_table
    frame = pd.DataFrame({"parameter": ["mass_kg", "efficiency", "davis_c", "noise"],
                          "estimate": [255200.0, 0.8537, 6.97, 1e-9], "std": [312.5, 0.000213, 0.2446, 0.0]})
    html = data_table(frame)
    for text in (">255\u2009200.000<", ">0.8537<", ">6.970<", ">0.000213<", ">0.2446<", ">312.5<"):
        assert text in html, (text, html)
    assert 'data-v="1e-09">0.000<' in html, html
