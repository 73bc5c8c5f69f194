"""What calibration and validation make of logs that do not say what they seem to: a line power in
another unit, logs of other lines pooled, header fields that contradict the columns or are needed
only without the command line's files, a log that starts moving, a logged train stronger than its
file, a fit that cannot tell the static mass from the rotating-mass allowance. Each is refused in
one line, warned of by name or flagged with the reason, never an `ok` calibration (real fits on
generated logs of the regional train)."""
import dataclasses
import json
import re
import warnings

import pytest
import yaml
from typer.testing import CliRunner

from ecostudy.calibration.estimate import calibrate_logs
from ecostudy.calibration.fit import DEFAULT_FIT
from ecostudy.calibration.generate import LogNoise, generate_log, true_train
from ecostudy.calibration.replay import prepare
from ecostudy.calibration.validate import validate_log
from ecostudy.cli import app
from ecostudy.core.errors import EcostudyWarning, InputError
from ecostudy.io.loaders import load_track, load_train
from ecostudy.io.logfile import parse_log, write_log

from .conftest import TRACKS, TRAINS

TRAIN, TRACK = TRAINS / "regional_alstom.yaml", TRACKS / "calibration_line.yaml"
OTHER_TRACK = TRACKS / "metro_line_4stops.yaml"


def run(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def text_of(frame, header="---\ntrack: t.yaml\ntrain: r.yaml\n---\n"):
    return header + frame.to_csv(index=False, float_format="%.6f")


@pytest.fixture(scope="module")
def inputs():
    return load_track(TRACK), load_train(TRAIN)


@pytest.fixture(scope="module")
def there(inputs):
    """A log of the train as its file gives it, West -> Middle -> East (10 Hz, 1 % power noise)."""
    return generate_log(inputs[0], inputs[1], ["West", "Middle", "East"], inputs[1], seed=1)[0]


@pytest.mark.parametrize("scale, low, high", [(1e-3, 500, 2000), (0.8, 1.05, 1.2)])
def test_a_line_power_in_another_unit_or_scale_is_refused(there, scale, low, high):
    """kW written under a W name reads 1000 times too small; a line power 0.8 times the truth (a
    voltage scale off) gives the wheel more than the line gives: each fitted an efficiency of 854
    or 1.07 and said `ok` (`validate`: ok beside a 1000-times line energy). Now one line."""
    frame = there.assign(power_line_kW=there["power_line_kW"] * scale)
    with pytest.raises(InputError, match=r"log.csv: power_line_kW: the wheel power is [0-9.]+ times the line "
                                         "power .* in another unit or scale than its name says") as refused:
        parse_log(text_of(frame), "log.csv")
    assert low < float(str(refused.value).split("the wheel power is ")[1].split()[0]) < high


def test_a_start_position_that_contradicts_the_positions_is_refused(there):
    header = "---\ntrack: t.yaml\ntrain: r.yaml\nstart_position_m: 5000\n---\n"
    with pytest.raises(InputError, match=r"header.start_position_m: 5000 m, but position_m starts at 300 m"):
        parse_log(text_of(there, header), "log.csv")


def test_logs_of_other_lines_are_not_pooled(tmp_path, there):
    """The second log's header names another line: refused before fitting (it was pooled with the
    first, `calibration ok`); given --track, each log is replayed on it and the other header named."""
    write_log(tmp_path / "a.csv", {"track": str(TRACK), "train": str(TRAIN)}, there)
    write_log(tmp_path / "b.csv", {"track": str(OTHER_TRACK), "train": str(TRAIN)}, there.iloc[::-1].assign(
        time_s=there["time_s"].to_numpy()))
    refused = run("calibrate", tmp_path / "a.csv", tmp_path / "b.csv", "--no-plot", "--out", tmp_path / "o")
    assert refused.exit_code == 2 and not (tmp_path / "o").exists(), refused.output
    assert f"b.csv: header.track: names {OTHER_TRACK.resolve()}, but the first log's names {TRACK.resolve()}" \
        in refused.output, refused.output
    given = run("calibrate", tmp_path / "a.csv", tmp_path / "b.csv", "--track", TRACK, "--bootstrap", 0, "--no-plot",
                "--out", tmp_path / "o2")
    assert f"b.csv: header.track: names {OTHER_TRACK.resolve()}; replayed on --track" in given.output, given.output


def test_a_header_without_its_train_reads_with_the_train_given(tmp_path, there):
    write_log(tmp_path / "a.csv", {"track": str(TRACK)}, there)
    missing = run("validate", tmp_path / "a.csv", "--no-plot", "--out", tmp_path / "o")
    assert missing.exit_code == 2 and "a.csv: header.train: missing: name the train file" in missing.output
    given = run("validate", tmp_path / "a.csv", "--train", TRAIN, "--no-plot", "--out", tmp_path / "o2")
    assert given.exit_code == 0 and "validate: ok" in given.output, given.output


def test_a_log_that_starts_moving_says_what_is_not_replayed(inputs, there):
    moving = there[(there["position_m"] > 2000) & (there["time_s"] < 400)].reset_index(drop=True)
    with pytest.warns(EcostudyWarning, match=r"log.csv: speed: the log starts moving \(.* m/s at 20.. m\): its first "
                                             r"\d+ s and \d+ m, before the first stand, are not replayed"):
        runs = prepare(parse_log(text_of(moving), "log.csv"), *inputs)
    assert runs[0].x[0] > 5000


def test_a_first_sample_within_the_logs_noise_or_resolution_is_at_rest(inputs):
    """A generated log with 0.3 m/s of speed noise (seed 2) reads 0.293 m/s in its first sample, the
    train standing: above 0.25 m/s, the log "started moving" and lost its whole first run (200 s,
    5100 m) though its header states the noise. Now a first sample within 3 times the stated noise
    (unstated: the noise read off the speeds' second differences, 0.306 m/s here), or within one
    step of the speed column's last digit (1 km/h read at a stand), is at rest; one beyond both
    still starts the log moving."""
    track, train = inputs
    frame = generate_log(track, train, ["West", "Middle", "East"], train, seed=2, noise=LogNoise(speed=0.3))[0]
    assert 0.25 < frame["speed_mps"].iloc[0] < 0.3
    stated = "---\ntrack: t.yaml\ntrain: r.yaml\nspeed_sigma_mps: 0.3\n---\n"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "the log starts moving"
        assert len(prepare(parse_log(text_of(frame, stated), "noisy.csv"), track, train)) == 2
        assert len(prepare(parse_log(text_of(frame), "unstated.csv"), track, train)) == 2  # noise read off the log
        kmh = frame.assign(speed_mps=(frame["speed_mps"] * 3.6).round()).rename(columns={"speed_mps": "speed_kmh"})
        kmh.loc[0, "speed_kmh"] = 1.0
        assert len(prepare(parse_log(text_of(kmh), "kmh.csv"), track, train)) == 2
    moving = frame.assign(speed_mps=frame["speed_mps"].where(frame.index > 0, 1.0))
    with pytest.warns(EcostudyWarning, match=r"moving.csv: speed: the log starts moving \(1.0 m/s at 300 m\)"):
        assert len(prepare(parse_log(text_of(moving, stated), "moving.csv"), track, train)) == 1


def test_a_declared_speed_noise_is_used(inputs, there):
    header = "---\ntrack: t.yaml\ntrain: r.yaml\nspeed_sigma_mps: 0.2\n---\n"
    result = calibrate_logs([parse_log(text_of(there, header), "log.csv")], *inputs, ("mass", "davis_a"), draws=0)
    assert result.quality["noise"]["speed_mps"] == 0.2


def test_traction_beyond_the_train_files_envelope_is_flagged(inputs, there):
    """The log's train pulls 300 kN; the file it is calibrated against has 60 % of that. The replay
    reads the logged work, so the fit was `ok`; the calibrated file could not drive the log."""
    track, train = inputs
    weak = dataclasses.replace(train, traction=train.traction.scaled(0.6))
    result = calibrate_logs([parse_log(text_of(there), "log.csv")], track, weak, ("mass", "davis_a"), draws=0)
    assert result.status == "flagged" and "log: logged traction" in result.reason and \
        "times the train file's envelope" in result.reason, result.reason


def test_a_flagged_calibration_writes_a_train_file_that_says_so(tmp_path, there):
    write_log(tmp_path / "a.csv", {"track": str(TRACK), "train": str(TRAIN)}, there.drop(columns=["power_line_kW"]))
    result = run("calibrate", tmp_path / "a.csv", "--fit", "mass,efficiency", "--no-plot", "--out", tmp_path / "o")
    assert result.exit_code == 1 and "calibration flagged (each reason below)" in result.output, result.output
    assert "not all of" not in result.output  # the line named every check as if each had failed
    source = yaml.safe_load((tmp_path / "o" / "regional_alstom_calibrated.yaml").read_text())["source"]
    assert source.startswith("NOT OK, calibration flagged: efficiency not identifiable"), source


def test_savings_of_a_run_the_file_cannot_drive_name_it_and_go_on(tmp_path, there):
    """Against a train file with 60 % of the logged traction each run's logged time is below the
    file's fastest (199.7 s for 197.3 s, 195.8 s for 195.4 s): each savings row fails saying so,
    the second run is tried after the first failed, the folder is whole and the command exits 1
    (it stopped at the first with exit 2, no run named, no summary)."""
    doc = yaml.safe_load(TRAIN.read_text())
    doc["traction"]["table"]["force_kN"] = [0.6 * f for f in doc["traction"]["table"]["force_kN"]]
    (tmp_path / "weak.yaml").write_text(yaml.safe_dump(doc))
    write_log(tmp_path / "a.csv", {"track": str(TRACK), "train": str(tmp_path / "weak.yaml")}, there)
    result = run("calibrate", tmp_path / "a.csv", "--savings", 0, "--no-plot", "--out", tmp_path / "o")
    assert result.exit_code == 1, result.output
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert [r["run"] for r in summary["savings"]] == [0, 1]
    for row in summary["savings"]:
        assert row["status"].startswith("failed: infeasible: the fastest possible run takes") and \
            "the calibrated train cannot drive the logged time" in row["status"], row
    assert "a run 0: failed: infeasible" in result.output and "times the train file's envelope" in result.output


def test_a_parameter_fitted_at_its_bound_is_flagged(inputs):
    """Logs of a train whose rotating-mass allowance is twice its file's, fitted with f held: Davis
    B goes to its bound 0 with an interval of +-27.5 N s/m about it, reported identifiable (the
    calibration was flagged for the residuals' drift alone). An interval reaching below the bound is
    not identifiable: B is held, the reason saying so."""
    track, train = inputs
    truth = true_train(train, rotating=2.0)
    logs = [parse_log(text_of(generate_log(track, truth, stops, truth, seed=seed)[0]), f"l{seed}.csv")
            for seed, stops in ((1, ["West", "Middle", "East"]), (2, ["East", "Middle", "West"]))]
    result = calibrate_logs(logs, track, train, DEFAULT_FIT, draws=0)
    assert result.status == "flagged" and re.search(r"davis_b not identifiable from these logs, held at its prior: "
                                                    r"95 % half-width [0-9.]+ N s/m, [0-9]+ % of the running resistance "
                                                    r"over the logged speeds \(limit 20 %\); its interval -[0-9.]+ to "
                                                    r"[0-9.]+ N s/m reaches below the bound 0", result.reason), result.reason
    assert not result.table.set_index("name").loc["davis_b", "identifiable"]


@pytest.mark.parametrize("broken", ["flipped", "dead"])
def test_a_line_power_with_its_sign_flipped_or_dead_is_warned_and_left_out(inputs, there, broken):
    """validate wrote a logged line traction of 17.71 kWh (the flipped channel's braking) or 0 against
    the true 71.46, with nothing said: the line/wheel ratio check needs 10 rows where both are
    positive and was skipped. Now warned naming the column, and left out of the efficiency fit and
    of validate's logged line energy (NaN)."""
    frame = there.assign(power_line_kW=-there["power_line_kW"] if broken == "flipped" else 0.0)
    with pytest.warns(EcostudyWarning, match=r"log.csv: power_line_kW: positive in 0 of the \d+ rows where the wheel "
                                             r"power is positive above 3 m/s .* a sign flipped \(drawn is positive\) or "
                                             r"a dead channel: left out"):
        log = parse_log(text_of(frame), "log.csv")
    table = validate_log(log, *inputs)
    assert table["logged_line_traction_kWh"].isna().all() and (table["model_line_traction_kWh"] > 50).all(), table
    result = calibrate_logs([log], *inputs, ("mass", "efficiency"), draws=0)
    assert result.reason.startswith("efficiency not identifiable from these logs"), result.reason


def map_train(tmp_path):
    """The regional train's file with a flat traction efficiency map beside its constant."""
    data = yaml.safe_load(TRAIN.read_text())
    data["traction_efficiency_map"] = {"speed_kmh": [0, 70, 140], "force_kN": [0, 150, 300],
                                       "efficiency": [[0.88] * 3] * 3}
    path = tmp_path / "mapped.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_a_fitted_efficiency_replaces_the_train_file_map_saying_so(tmp_path, there):
    """The fit compares a constant efficiency with the logged line power; the calibrated file kept
    the map beside the fitted constant, and the net energy uses the map (5 % low on the audit's
    logs). Now the map is left out, with a warning naming it."""
    write_log(tmp_path / "a.csv", {"track": str(TRACK), "train": str(TRAIN)}, there)
    result = run("calibrate", tmp_path / "a.csv", "--train", map_train(tmp_path), "--fit", "mass,efficiency",
                 "--bootstrap", 0, "--no-plot", "--out", tmp_path / "o")
    assert result.exit_code == 0, result.output
    assert "mapped.yaml: traction_efficiency_map: left out of the calibrated train" in result.output, result.output
    calibrated = load_train(tmp_path / "o" / "mapped_calibrated.yaml")
    assert calibrated.traction_efficiency_map is None and calibrated.eta_traction == calibrated.traction_efficiency
    assert abs(calibrated.traction_efficiency - load_train(TRAIN).traction_efficiency) < 0.01


def test_a_regeneration_efficiency_of_a_train_without_regenerative_braking_is_refused(tmp_path, there):
    """Its prior is 0: the fit ran, its reason printed a 310-digit percentage. Now one line, exit 2,
    before computing."""
    data = yaml.safe_load(TRAIN.read_text())
    del data["regenerative_braking"]
    (tmp_path / "noregen.yaml").write_text(yaml.safe_dump(data))
    write_log(tmp_path / "a.csv", {"track": str(TRACK), "train": str(TRAIN)}, there)
    result = run("calibrate", tmp_path / "a.csv", "--train", tmp_path / "noregen.yaml", "--fit",
                 "mass,regeneration_efficiency", "--no-plot", "--out", tmp_path / "o")
    assert result.exit_code == 2 and not (tmp_path / "o").exists(), result.output
    assert "error: command line: --fit: regeneration_efficiency: the train file " in result.output
    assert "has no regenerative_braking" in result.output and "Traceback" not in result.output


def test_auxiliary_power_in_the_line_power_is_flagged_with_what_it_draws(inputs, there):
    """200 kW of auxiliaries in the line power pulled the fitted efficiency from 0.8536 to 0.798, its
    interval 0.797-0.799 and `ok`. The line draws it while the wheels draw nothing: now flagged."""
    track, train = inputs
    clean = calibrate_logs([parse_log(text_of(there), "clean.csv")], track, train, ["efficiency"], draws=0)
    assert "wheels draw none" not in clean.reason
    frame = there.assign(power_line_kW=there["power_line_kW"] + 200.0)
    flagged = calibrate_logs([parse_log(text_of(frame), "aux.csv")], track, train, ["efficiency"], draws=0)
    assert flagged.status == "flagged" and "aux: power_line_kW draws 200 kW (median over" in flagged.reason, flagged.reason
    assert "while the wheels draw none (standing, coasting)" in flagged.reason


def test_a_wheel_power_off_in_scale_from_the_force_is_flagged_naming_both(inputs, there):
    """A wheel power 10 % above force times speed (1.10, within the unit check's 0.8-1.25) was fitted
    `ok`, the mass taking it up (+10 %). Now flagged naming both columns; the generated log is not."""
    track, train = inputs
    clean = calibrate_logs([parse_log(text_of(there), "clean.csv")], track, train, list(DEFAULT_FIT), draws=0)
    assert "power_wheel_kW is" not in clean.reason, clean.reason
    frame = there.assign(power_wheel_kW=there["power_wheel_kW"] * 1.1,
                         power_line_kW=there["power_line_kW"] * 1.1)
    flagged = calibrate_logs([parse_log(text_of(frame), "w10.csv")], track, train, list(DEFAULT_FIT), draws=0)
    assert flagged.status == "flagged", flagged.reason
    assert "w10: power_wheel_kW is 1.101 times force_kN times speed_mps" in flagged.reason, flagged.reason


def test_one_log_exported_twice_with_rows_trimmed_is_refused(tmp_path, there):
    """The same run with 25 rows cut at its start and 10 at its end (another export) was fitted as a
    second run (the same-samples check needs the same row count). Now refused naming both."""
    write_log(tmp_path / "a.csv", {"track": str(TRACK), "train": str(TRAIN)}, there)
    write_log(tmp_path / "b.csv", {"track": str(TRACK), "train": str(TRAIN)}, there.iloc[25:-10])
    result = run("calibrate", tmp_path / "a.csv", tmp_path / "b.csv", "--bootstrap", 0, "--no-plot",
                 "--out", tmp_path / "o")
    assert result.exit_code == 2 and not (tmp_path / "o").exists(), result.output
    rows = len(there) - 35
    assert f"b.csv: its rows 1-{rows} are the samples of {tmp_path / 'a.csv'}'s rows 26-{rows + 25} (one logged run" \
        in result.output, result.output


def test_a_flagged_calibrations_train_flags_every_run_of_it(tmp_path, there):
    """The calibrated file of a flagged calibration said NOT OK only in its `source` text: `solve` on it
    was ok, exit 0. Now its `calibration` block (status and reason) is read by the loader and every run
    of the train is flagged with the reason (`solve`'s, each of `compare`'s); the same file with `status: ok` solves ok (the block
    decides, not the source text); a block without its reason is refused in one line."""
    write_log(tmp_path / "a.csv", {"track": str(TRACK), "train": str(TRAIN)}, there.drop(columns=["power_line_kW"]))
    run("calibrate", tmp_path / "a.csv", "--fit", "mass,efficiency", "--no-plot", "--out", tmp_path / "o")
    path = tmp_path / "o" / "regional_alstom_calibrated.yaml"
    block = yaml.safe_load(path.read_text())["calibration"]
    assert block["status"] == "flagged" and block["reason"].startswith("efficiency not identifiable"), block
    solved = run("solve", "--track", TRACK, "--train", path, "--from", "West", "--to", "Middle", "--time", 240,
                 "--points", 60, "--no-plot", "--out", tmp_path / "s")
    assert solved.exit_code == 1, solved.output
    status = json.loads((tmp_path / "s" / "summary.json").read_text())["status"]
    assert status.startswith("flagged: train calibrated with status flagged: efficiency not identifiable"), status
    compared = run("compare", "--track", TRACK, "--train", path, "--from", "West", "--to", "Middle", "--time", 240,
                   "--points", 60, "--no-plot", "--out", tmp_path / "c")
    summary = json.loads((tmp_path / "c" / "summary.json").read_text())
    rows = summary["not_ok"]
    assert compared.exit_code == 1 and len(rows) == summary["cases"]["total"] and all("train calibrated with status flagged: efficiency not identifiable"
                                                    in row["status"] for row in rows), rows
    validated = run("validate", tmp_path / "a.csv", "--train", path, "--no-plot", "--out", tmp_path / "v")
    summary = json.loads((tmp_path / "v" / "summary.json").read_text())
    assert validated.exit_code == 1 and "train: train calibrated with status flagged: efficiency not identifiable" \
        in summary["status"], (validated.output, summary["status"])
    doc = yaml.safe_load(path.read_text())
    (tmp_path / "ok.yaml").write_text(yaml.safe_dump({**doc, "calibration": {"status": "ok"}}))
    ok = run("solve", "--track", TRACK, "--train", tmp_path / "ok.yaml", "--from", "West", "--to", "Middle", "--time",
             240, "--points", 60, "--no-plot", "--out", tmp_path / "s2")
    assert ok.exit_code == 0, ok.output
    validated = run("validate", tmp_path / "a.csv", "--train", tmp_path / "ok.yaml", "--no-plot", "--out", tmp_path / "v2")
    assert "train calibrated" not in json.loads((tmp_path / "v2" / "summary.json").read_text())["status"]
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump({**doc, "calibration": {"status": "flagged"}}))
    with pytest.raises(InputError, match=r"bad.yaml: calibration: .*a flagged calibration needs its reason"):
        load_train(tmp_path / "bad.yaml")


def test_a_held_parameter_the_logs_exclude_is_flagged(inputs, there):
    """Logs of a train whose rotating-mass allowance is 1.25 times its file's, fitted with the allowance
    held at the file's value (the default fit): `ok`, with the mass and Davis intervals missing the
    truth. The logs identify the allowance: fitted beside the others it comes out 0.060 against the
    held 0.048, several half-widths of its interval away: now flagged saying so. The file's own
    train's log is not."""
    track, train = inputs
    clean = calibrate_logs([parse_log(text_of(there), "clean.csv")], track, train, DEFAULT_FIT, draws=0)
    assert "is excluded by the logs" not in clean.reason, clean.reason
    truth = true_train(train, rotating=1.25)
    frame = generate_log(track, truth, ["West", "Middle", "East"], truth, seed=1)[0]
    result = calibrate_logs([parse_log(text_of(frame), "heavy.csv")], track, train, DEFAULT_FIT, draws=0)
    mass = result.table.set_index("name").loc["mass"]
    assert not mass.low <= truth.static_mass <= mass.high  # what the check is for
    assert result.status == "flagged" and re.search(
        r"held rotating_mass_factor = 0.04806 is excluded by the logs \(they give 0.06\d* \+- 0.00\d+, [\d.]+ "
        r"half-widths of their 95 % interval away\); fit it \(--fit \.\.\.,rotating_mass_factor\) or check the train "
        "file", result.reason), result.reason
    assert set(clean.quality["held_fitted"]) == {"rotating_mass_factor", "regeneration_efficiency"}  # summary.json
    held = result.quality["held_fitted"]["rotating_mass_factor"]
    assert held["fitted"] - held["held"] > 2 * held["half_width"]
    assert abs(held["fitted"] - 1.25 * held["held"]) < 2 * held["half_width"]  # and it finds the truth


def test_the_ok_line_lists_every_check_it_ran(tmp_path, inputs, there):
    """The ok line listed five checks; the auxiliary-power, force/power and speed-scale checks (and
    the fit's convergence, the mass ratio, the efficiencies at most 1) ran unnamed. Now it names every
    check run, and one that ran on no log (no force column: no force/power check) is not named."""
    write_log(tmp_path / "a.csv", {"track": str(TRACK), "train": str(TRAIN)}, there)
    result = run("calibrate", tmp_path / "a.csv", "--bootstrap", 0, "--no-plot", "--out", tmp_path / "o")
    assert result.exit_code == 0, result.output
    line = next(line for line in result.output.splitlines() if line.startswith("calibration ok: "))
    for check in ("every parameter fitted identifiable and none at its bound 0", "the least-squares fit converged",
                  "fitted efficiencies at most 1", "the mass within 1/3 to 3 times the train file's",
                  "replayed speed within 0.3 m/s RMS", "innovations within 2 times white noise over 5 s",
                  "logged speeds within 1 km/h of the line's limits", "logged traction within the train file's envelope",
                  "speeds and positions on one scale", "the wheel power 0.95-1.06 times the force times the speed",
                  "no auxiliary power in the line power while the wheels draw none",
                  "held rotating_mass_factor, regeneration_efficiency within 2 half-widths"):
        assert check in line, (check, line)
    assert json.loads((tmp_path / "o" / "summary.json").read_text())["checks"] == line[len("calibration ok: "):].split("; ")
    bare = calibrate_logs([parse_log(text_of(there.drop(columns=["force_kN"])), "bare.csv")], *inputs, ("mass", "davis_a"),
                          draws=0)
    assert bare.status == "ok" and not any("force" in check or "auxiliary" in check for check in bare.checked), bare.checked
