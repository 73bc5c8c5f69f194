"""Every command's options fuzzed through the command line itself (Typer's CliRunner): one to three
options of a small, valid command replaced by hostile values (empty, blank, NaN, inf, 1e400,
negative, zero, text, separators, huge). Whatever comes in, the command refuses it in one line
(exit 2) or computes a result that is ok or flagged (exit 0 or 1): never an internal error (exit 3),
a traceback or a hang past the bound. The fast profile runs a small budget in ``make test``; the
deep one (``-m slow``) many more (``tests/test_fuzz.py`` holds the profiles)."""
import pytest
from hypothesis import strategies as st
from typer.testing import CliRunner

from ecostudy.cli import app

from .conftest import STUDIES, TRACKS, TRAINS, load_yaml, write_yaml
from .test_fuzz import bounded, fuzz

pytestmark = [pytest.mark.filterwarnings("ignore::ecostudy.core.errors.EcostudyWarning")]

METRO, AMS, LINE4 = TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml", TRACKS / "metro_line_4stops.yaml"
HOSTILE = ["", " ", "nan", "NaN", "inf", "-inf", "1e400", "-1", "0", "-0", "1e-300", "1e308", "abc", "10,", ",",
           "1,2,3", "[, 56]", "\u00e9t\u00e9", "0x10", "1_000", "10", "3", "Rokin", "Noord,Station", "10s", "-5m",
           "png", "minlp"]
VALUES = st.one_of(st.sampled_from(HOSTILE), st.text(max_size=8))

# each command: a small valid call (its output folder last) and the options fuzzed
COMMANDS = {
    "solve": (["--track", AMS, "--train", METRO, "--time", "80", "--points", "20", "--no-plot"],
              ["--time", "--supplement", "--window", "--from", "--to", "--objective", "--weights", "--points",
               "--das", "--format", "--dpi"]),
    "pareto": (["--track", AMS, "--train", METRO, "--count", "3", "--points", "20", "--no-plot"],
               ["--count", "--supplement-max", "--workers", "--weighted", "--points", "--from", "--to", "--das",
                "--format", "--dpi"]),
    "compare": (["--track", AMS, "--train", METRO, "--time", "80", "--points", "20", "--no-plot"],
                ["--time", "--supplement", "--points", "--from", "--to", "--format", "--dpi"]),
    "journey": (["--track", LINE4, "--train", METRO, "--stops", "Noord,Station", "--time", "100", "--points", "20",
                 "--no-plot"], ["--stops", "--time", "--supplement", "--dwell", "--workers", "--points", "--dpi"]),
    "run": (["--no-progress"], ["--workers", "--dask"]),
    "network": (["--no-plot"], ["--workers", "--format", "--dpi"]),
    "simulate": (["--no-progress", "--no-plot"], ["--workers", "--only", "--dask"]),
    "heavyhaul": (["--no-progress", "--no-plot"], ["--workers", "--blas-threads", "--dask"]),
    "check": ([], ["--time"]),
    "export": ([], ["--every"]),
}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """Study files for the commands that read one (each small enough to compute in seconds, or
    refused after its options for a reason of its own), and a solved run for check and export."""
    tmp = tmp_path_factory.mktemp("fuzzcli")
    run = {"name": "one", "track": str(AMS), "train": str(METRO), "points": 20, "objective": "energy",
           "sweep": {"supplement_percent": [10]}}
    loop = {"name": "loop", "track": str(AMS), "train": str(METRO), "window_s": [0, 76], "points": 50,
            "sample_time_s": 1.0, "controllers": [{"name": "ato", "kind": "ato"}], "draws": 1}
    net = load_yaml(STUDIES / "network_metro_2trains.yaml")
    net.update(track=str(LINE4), train=str(METRO), stops=["Noord", "Nowhere"])  # refused: an unknown stop
    heavy = load_yaml(STUDIES / "heavyhaul_fence.yaml")
    heavy.update(consist=str((STUDIES / heavy["consist"]).resolve()), track=str((STUDIES / heavy["track"]).resolve()),
                 fence=[999])  # refused: more groups than cars
    saved = tmp / "saved"
    r = CliRunner().invoke(app, ["solve", "--track", str(AMS), "--train", str(METRO), "--time", "80", "--points", "30",
                                 "--no-plot", "--out", str(saved)])
    assert r.exit_code == 0, r.output
    return {"run": write_yaml(tmp / "run.yaml", run), "simulate": write_yaml(tmp / "loop.yaml", loop),
            "network": write_yaml(tmp / "net.yaml", net), "heavyhaul": write_yaml(tmp / "hh.yaml", heavy),
            "check": saved, "export": saved}


def argv(command, options, inputs, out):
    base, _ = COMMANDS[command]
    words = [str(w) for w in base]
    for name, value in options.items():
        if name in words:
            i = words.index(name)
            del words[i:i + 2]
        words += [name, value]
    head = [command] + ([str(inputs[command])] if command in inputs else [])
    tail = [] if command in ("check", "export") else ["--out", str(out)]
    return head + words + tail


def calls():
    return st.sampled_from(sorted(COMMANDS)).flatmap(lambda c: st.tuples(
        st.just(c), st.dictionaries(st.sampled_from(COMMANDS[c][1]), VALUES, min_size=1, max_size=3)))


def _command_options(inputs, tmp_path_factory, call):
    command, options = call
    out = tmp_path_factory.mktemp("o", numbered=True) / "out"
    words = argv(command, options, inputs, out)
    with bounded():
        r = CliRunner().invoke(app, words)
    assert r.exit_code in (0, 1, 2), f"{words}: exit {r.exit_code}\n{r.output}"
    assert "Traceback" not in r.output, f"{words}\n{r.output}"
    if r.exit_code == 2:  # Click's own refusals (a type, a range) too: one line, no usage box
        errors = [x for x in r.output.splitlines() if x.startswith("error:")]
        assert "Usage:" not in r.output, f"{words}\n{r.output}"
        # one line per problem (all problems of the input are reported together), each naming its place
        assert errors and all(x.count(":") >= 2 for x in errors), f"{words}\n{r.output}"


test_command_options, test_command_options_deep = fuzz(calls(), fast=20, deep=400)(_command_options)


def test_every_command_is_fuzzed():
    """The fuzzed commands are every command that computes or reads a study (the others take no
    option that reaches the library: doctor, calibrate and validate are fuzzed through their files)."""
    names = {c.name or c.callback.__name__ for c in app.registered_commands}
    assert set(COMMANDS) <= names and names - set(COMMANDS) <= {"doctor", "calibrate", "validate"}, names
