"""`ecostudy run --kind simulate|heavyhaul|network` writes the files of the kind's own command
(through the same writers), so that one command after the other into one folder leaves only the
last one's files there, each listed in its summary.json (and report.html); the own command's
--no-plot after a run that drew removes the figures. Each on the smallest study of its tests, the
second command re-using the stored runs."""
import json

from typer.testing import CliRunner

from ecostudy.cli import app

from .test_heavyhaul_study import study as heavyhaul_study
from .test_network import tiny_network_study
from .test_simulate import study as loop_study

runner = CliRunner()


def invoke(*args):
    result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code in (0, 1) and "Traceback" not in result.output, result.output
    return result


def listed_exactly(folder):
    """The files in ``folder`` are those its summary.json and report.html list (a closed-loop study's
    steps/ files too: they were written and not listed); returns them."""
    files = set(json.loads((folder / "summary.json").read_text())["files"])
    top = {f for f in files if "/" not in f}
    assert {p.name for p in folder.iterdir() if p.is_file()} == top, files
    inside = {f"{d.name}/{p.name}" for d in folder.iterdir() if d.is_dir() for p in d.iterdir()}
    assert inside == files - top, (inside, files)
    html = (folder / "report.html").read_text()
    assert all(f'href="./{name}"' in html for name in files - {"report.html"}), files
    return files


def test_run_kind_simulate_writes_the_files_of_simulate(tmp_path):
    """simulate (one controller, one draw), run --kind simulate (aggregate.csv, steps/ and the
    figures rewritten from the stored run, listed), simulate --no-plot (the figures removed)."""
    path, out = loop_study(tmp_path, draws=1, controllers=[{"name": "convex", "kind": "convex", "estimator": True,
                                                             "compute_delay": 0}]), tmp_path / "out"
    invoke("simulate", path, "--out", out, "--workers", 1, "--no-progress")
    figures = {"bands.png", "solve_times.png", "mass_estimates.png"}
    assert figures | {"aggregate.csv"} <= listed_exactly(out)
    invoke("run", path, "--kind", "simulate", "--out", out, "--workers", 1, "--no-progress")
    assert figures | {"aggregate.csv"} <= listed_exactly(out)
    assert [p.name for p in (out / "steps").iterdir()] == ["convex_draw0.csv"]
    assert "steps/convex_draw0.csv" in listed_exactly(out)
    invoke("simulate", path, "--out", out, "--workers", 1, "--no-progress", "--no-plot")
    assert not figures & listed_exactly(out) and "aggregate.csv" in listed_exactly(out)


def test_run_kind_heavyhaul_writes_the_files_of_heavyhaul(tmp_path):
    """heavyhaul (one K_b, capped at 24 samples), run --kind heavyhaul (its two figures redrawn and
    listed), heavyhaul --no-plot (removed)."""
    path, out = heavyhaul_study(tmp_path, brake_penalty=[1], max_samples=24), tmp_path / "out"
    figures = {"tracking.png", "forces_K_b1_f10_Np4_Nc2.png"}
    invoke("heavyhaul", path, "--out", out, "--workers", 1, "--no-progress")
    assert figures <= listed_exactly(out)
    invoke("run", path, "--kind", "heavyhaul", "--out", out, "--workers", 1, "--no-progress")
    assert figures <= listed_exactly(out)
    invoke("heavyhaul", path, "--out", out, "--workers", 1, "--no-progress", "--no-plot")
    assert not figures & listed_exactly(out)


def test_run_kind_network_writes_the_files_of_network(tmp_path):
    """run --kind network (the independent strategy of two trains), then network into the same
    folder, then run --kind network again: each time the trains' and steps' tables, network.json
    and both figures, listed."""
    path, out = tiny_network_study(tmp_path, ["independent"]), tmp_path / "out"
    own = {"network_substation.csv", "network_trains.csv", "network_steps_independent.csv", "network.json",
           "network.png", "network_supply.png"}
    invoke("run", path, "--kind", "network", "--out", out, "--workers", 1, "--no-progress")
    assert own <= listed_exactly(out)
    invoke("network", path, "--out", out, "--workers", 1, "--no-plot")
    assert own - {"network.png", "network_supply.png"} == listed_exactly(out) - {"summary.json", "report.html",
                                                                                 "results.sqlite"}
    invoke("run", path, "--kind", "network", "--out", out, "--workers", 1, "--no-progress")
    assert own <= listed_exactly(out)


def test_run_kind_no_plot_writes_the_files_of_the_command_without_its_figures(tmp_path):
    """run --kind network --no-plot: the tables and network.json of `network --no-plot`, no figure;
    run --kind network then draws them."""
    path, out = tiny_network_study(tmp_path, ["independent"]), tmp_path / "out"
    tables = {"network_substation.csv", "network_trains.csv", "network_steps_independent.csv", "network.json"}
    invoke("run", path, "--kind", "network", "--out", out, "--workers", 1, "--no-progress", "--no-plot")
    assert listed_exactly(out) - {"summary.json", "report.html", "results.sqlite"} == tables
    invoke("run", path, "--kind", "network", "--out", out, "--workers", 1, "--no-progress")
    assert tables | {"network.png", "network_supply.png"} <= listed_exactly(out)


def test_a_figure_the_study_no_longer_draws_is_not_kept_from_an_earlier_run(tmp_path):
    """The study's controller loses its estimator between two runs of simulate into one folder: the
    second run draws no mass_estimates.png, so the first run's is removed, not listed as drawn."""
    controller = {"name": "convex", "kind": "convex", "estimator": True, "compute_delay": 0}
    path, out = loop_study(tmp_path, draws=1, controllers=[controller]), tmp_path / "out"
    invoke("simulate", path, "--out", out, "--workers", 1, "--no-progress")
    assert "mass_estimates.png" in listed_exactly(out)
    loop_study(tmp_path, draws=1, controllers=[{**controller, "estimator": False}])  # the same file, rewritten
    invoke("simulate", path, "--out", out, "--workers", 1, "--no-progress")
    assert {"bands.png", "solve_times.png"} <= listed_exactly(out) and not (out / "mass_estimates.png").exists()


def test_only_files_of_the_kinds_ecostudy_writes_are_removed(tmp_path):
    """A hand-edited summary.json that listed a user's own notes, study or train file (or a path out
    of the folder) never gets them removed: only an earlier run's csv, figure, json, html or sqlite
    file it no longer lists (no study kind writes a YAML file)."""
    from ecostudy.io.folder import remove_unlisted
    (tmp_path / "summary.json").write_text(json.dumps({"files": ["kept.csv"]}))
    mine = ("notes.txt", "notes", "study.yaml", "train.yaml")
    for name in ("kept.csv", "old.csv", "old.png", "old.svg", *mine):
        (tmp_path / name).write_text("x")
    (tmp_path.parent / "outside.csv").write_text("x")
    gone = remove_unlisted(tmp_path, ["kept.csv", "old.csv", "old.png", "old.svg", *mine, "../outside.csv"])
    assert gone == ["old.csv", "old.png", "old.svg"]
    assert {p.name for p in tmp_path.iterdir()} == {"summary.json", "kept.csv", *mine}
    assert (tmp_path.parent / "outside.csv").is_file()


def test_simulate_and_heavyhaul_write_their_figures_in_the_format_asked(tmp_path):
    """--format svg / pdf (and --dpi) reach every command's figures, not only the single-run ones:
    simulate and heavyhaul (and run --kind), their earlier png figures removed, the new ones listed;
    a format no writer knows is refused naming the option, before any run."""
    path, out = loop_study(tmp_path, draws=1, controllers=[{"name": "convex", "kind": "convex", "compute_delay": 0}]), \
        tmp_path / "loop"
    invoke("simulate", path, "--out", out, "--workers", 1, "--no-progress")
    invoke("simulate", path, "--out", out, "--workers", 1, "--no-progress", "--format", "svg")
    files = listed_exactly(out)
    assert {"bands.svg", "solve_times.svg"} <= files and not any(name.endswith(".png") for name in files), files
    assert not list(out.glob("*.png")), list(out.glob("*.png"))  # removed from the folder, not only from the list
    assert (out / "bands.svg").read_bytes().startswith(b"<?xml")
    invoke("run", path, "--kind", "simulate", "--out", out, "--workers", 1, "--no-progress", "--format", "pdf")
    assert (out / "bands.pdf").read_bytes().startswith(b"%PDF") and "bands.pdf" in listed_exactly(out)
    assert not list(out.glob("*.svg")), list(out.glob("*.svg"))
    hh, hh_out = heavyhaul_study(tmp_path, brake_penalty=[1], max_samples=24), tmp_path / "hh"
    invoke("heavyhaul", hh, "--out", hh_out, "--workers", 1, "--no-progress", "--format", "pdf", "--dpi", 50)
    assert {"tracking.pdf", "forces_K_b1_f10_Np4_Nc2.pdf"} <= listed_exactly(hh_out)
    refused = runner.invoke(app, ["simulate", str(path), "--out", str(tmp_path / "x"), "--format", "jpeg"])
    assert refused.exit_code == 2 and "--format: 'jpeg' is not a figure format" in refused.output
    assert not (tmp_path / "x").exists()
