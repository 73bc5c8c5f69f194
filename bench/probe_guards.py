"""Hostile-input probes of the guards, by class: every command given the inputs that once ended in a
silent wrong answer, an internal error, an unclear message, a runaway or a refusal of valid data.

    python bench/probe_guards.py [--src DIR] [--only CLASS] [--timeout S]

Each probe runs ``ecostudy`` in a fresh process (``--src``: the source tree put first on the path,
to probe another checkout) and is judged by its own rule: a refusal must be exit 2 with one
``error:`` line naming the fragment; a computed answer must hold what the probe checks. A probe that
ends in exit 3, a traceback or its timeout fails whatever it was meant to show. The hostile files
are written to a temporary folder, kept apart from the project's own files as a user's would be.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
TRAINS, TRACKS, STUDIES, DATA = ROOT / "trains", ROOT / "tracks", ROOT / "studies", ROOT / "tests" / "data"
METRO, AMS, LINE4 = TRAINS / "amsterdam_metro.yaml", TRACKS / "amsterdam_rokin_centraal.yaml", TRACKS / "metro_line_4stops.yaml"


def write(path, doc):
    path.write_text(yaml.safe_dump(doc, sort_keys=False) if path.suffix == ".yaml" else json.dumps(doc))
    return path


def load(path):
    return yaml.safe_load(Path(path).read_text())


def refused(*fragments):
    """A probe's rule: exit 2, one error line holding every fragment, no traceback."""
    def judge(r, out):
        lines = [x for x in r["output"].splitlines() if x.startswith("error:")]
        if r["code"] != 2 or len(lines) != 1 or "Traceback" in r["output"]:
            return False, f"exit {r['code']}, {len(lines)} error lines"
        missing = [f for f in fragments if f not in lines[0]]
        return not missing, ("missing " + repr(missing)) if missing else "refused"
    return judge


def computed(check, codes=(0, 1)):
    """A probe's rule: the command computes (exit 0 or 1) and ``check(output text, folder)`` holds."""
    def judge(r, out):
        if r["code"] not in codes or "Traceback" in r["output"]:
            return False, f"exit {r['code']}"
        try:
            ok, why = check(r["output"], out)
        except Exception as exc:  # noqa: BLE001 - a probe that cannot read its answer fails
            return False, f"{type(exc).__name__}: {exc}"
        return ok, why
    return judge


# ------------------------------------------------------------------------------------------ files
def alias_bomb(tmp):
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x]"]
    for i in range(1, 10):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]")
    (tmp / "bomb.yaml").write_text("\n".join(lines) + "\nname: bomb\n")
    return tmp / "bomb.yaml"


def loop_study(tmp, name, **fields):
    doc = {"name": name, "track": str(AMS), "train": str(METRO), "window_s": [0, 76], "points": 200,
           "sample_time_s": 0.1, "controllers": [{"name": "convex", "kind": "convex"}], "draws": 1,
           "output": str(tmp / f"out_{name}")}
    doc.update(fields)
    return write(tmp / f"{name}.yaml", doc)


def weak_train(tmp, share):
    text = (TRAINS / "yazhemsky2017_commuter.yaml").read_text()
    table = re.search(r"force_kN: \[([^\]]*)\]", text)
    forces = ", ".join(f"{float(x) * share:g}" for x in table.group(1).split(","))
    path = tmp / f"weak{share:g}.yaml"
    path.write_text(text[:table.start()] + f"force_kN: [{forces}]" + text[table.end():])
    return path


def hill(tmp):
    text = (TRACKS / "yazhemsky2017_advanced_1km.yaml").read_text()
    text = text.replace("{position_m: 200, gradient_permille: -20.3943}", "{position_m: 200, gradient_permille: 0}")
    path = tmp / "hill.yaml"
    path.write_text(text)
    return path


def network(tmp, name, **fields):
    doc = load(STUDIES / "network_metro_2trains.yaml")
    doc.pop("supplement_percent")
    doc.update(track=str(LINE4), train=str(METRO), output=str(tmp / f"out_{name}"), **fields)
    return write(tmp / f"{name}.yaml", doc)


def osrd_curve(tmp, points):
    import numpy as np
    doc = json.loads((DATA / "osrd_rolling_stock.json").read_text())
    speeds = np.linspace(0, 40, points)
    doc["effort_curves"]["modes"]["1500V"]["default_curve"] = {
        "speeds": speeds.tolist(), "max_efforts": np.interp(speeds, [0, 10, 20, 30, 40],
                                                            [2e5, 2e5, 1.1e5, 7.5e4, 5.6e4]).tolist()}
    return write(tmp / f"stock{points}.json", doc)


def study_scenario(tmp, name, scenario):
    doc = load(STUDIES / "metro_supplements.yaml")
    doc.update(track=str(AMS), train=str(METRO), output=str(tmp / f"out_{name}"), scenarios=[{"name": "bad", **scenario}])
    return write(tmp / f"{name}.yaml", doc)


def track_with_stop_name(tmp, name):
    doc = load(LINE4)
    doc["stops"][1]["name"] = name
    return write(tmp / "stops.yaml", doc)


def ttobench_train(tmp, power):
    doc = json.loads((DATA / "ttobench_subway_train.json").read_text())
    doc["max traction power"]["value"] = power
    return write(tmp / f"tto{power:g}.json", doc)


def saved_profile(tmp, src, edit):
    folder = tmp / f"saved_{edit}"
    if not (tmp / "saved").exists():
        run(src, ["solve", "--track", AMS, "--train", METRO, "--time", 80, "--points", 100, "--out", tmp / "saved",
                  "--no-plot"], 120)
    import shutil
    shutil.copytree(tmp / "saved", folder)
    lines = (folder / "profile.csv").read_text().splitlines()
    header = lines[0].split(",")
    if edit == "truncated":
        lines = lines[:40]
    else:
        cells = lines[5].split(",")
        cells[header.index("speed_kmh")] = {"nan": "nan", "text": "fast"}[edit]
        lines[5] = ",".join(cells)
    (folder / "profile.csv").write_text("\n".join(lines) + "\n")
    return folder


def library(tmp):
    """A TTOBench-format library whose only track is too fast for its only train: no case."""
    lib = tmp / "ttobench"
    (lib / "tracks").mkdir(parents=True, exist_ok=True)
    (lib / "trains").mkdir(exist_ok=True)
    (lib / "trains" / "subway.json").write_text((DATA / "ttobench_subway_train.json").read_text())
    doc = json.loads((DATA / "ttobench_track.json").read_text())
    doc["speed limits"]["values"] = [[0.0, 200]]
    write(lib / "tracks" / "T2.json", doc)
    return write(tmp / "lib.yaml", {"name": "lib", "library": {"path": "ttobench"}, "supplement_percent": 10,
                                    "output": str(tmp / "out_lib")})


def heavyhaul_reference(tmp, edit):
    doc = load(STUDIES / "heavyhaul_brake_penalty_limits.yaml")
    for key in ("consist", "track"):
        doc[key] = str((STUDIES / doc[key]).resolve())
    lines = (STUDIES / "heavyhaul_limit_reference.csv").read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[4].split(",")
    cells[header.index("speed_kmh")] = edit
    lines[4] = ",".join(cells)
    (tmp / "heavyhaul_limit_reference.csv").write_text("\n".join(lines) + "\n")
    doc["output"] = str(tmp / f"out_hh_{edit}")
    return write(tmp / f"hh_{edit}.yaml", doc)


# ------------------------------------------------------------------------------------------ checks
def csv_rows(path):
    import pandas as pd
    return pd.read_csv(path)


def front_rows(count):
    def check(text, out):
        n = len(csv_rows(out / "pareto.csv"))
        return n == count, f"{n} rows"
    return check


def no_plot_listed(text, out):
    line = next(x for x in text.splitlines() if x.strip().startswith("outputs"))
    return ".png" not in line, line.strip()[:80]


def journey_window_numbers(text, out):
    t = csv_rows(out / "journey.csv")
    from pandas.api.types import is_numeric_dtype
    windows = [c for c in t.columns if c.startswith(("arrival_", "departure_"))]  # the status may quote one
    ok = "arrival_latest_s" in t and all(is_numeric_dtype(t[c]) for c in windows)
    return ok, "number columns" if ok else "text windows"


def aggregate_no_empty(text, out):
    t = csv_rows(out / "aggregate.csv")
    numeric = t.select_dtypes("number")
    empty = int(numeric.isna().all(axis=1).sum())
    return empty == 0, f"{len(t)} rows, {empty} all-NaN"


def no_lock(text, out):
    return not (out / "results.sqlite.lock").exists(), "lock gone" if not (out / "results.sqlite.lock").exists() else "lock left"


def minlp_limit(limit):
    def check(text, out):
        das = json.loads((out / "summary.json").read_text())["das"]
        bound_line = next(x for x in text.splitlines() if "OA iterations" in x)
        ok = das["search_s"] <= limit * 1.1 + 1 and "no bound" in bound_line and "time limit" in das["status"]
        return ok, f"search {das['search_s']:.1f} s, {bound_line.strip()}"
    return check


def tto_power(text, out):
    s = json.loads((out / "summary.json").read_text())
    note = "never binds" in text
    return s["verification"]["passed"] and note, f"{s['traction_energy_kWh']:.9f} kWh" + (
        ", noted: the limit never binds" if note else ", no note")


# ------------------------------------------------------------------------------------------ probes
def probes(tmp, src):
    """(class, name, argv, rule, output folder, timeout [s])."""
    o = lambda n: tmp / f"o_{n}"  # noqa: E731
    bomb = alias_bomb(tmp)
    yield "regression", "alias bomb: run", ["run", bomb, "--no-progress"], refused("alias bomb"), None, 30
    yield "regression", "alias bomb: simulate", ["simulate", bomb, "--no-progress"], refused("alias bomb"), None, 30
    yield "regression", "alias bomb: network", ["network", bomb, "--no-plot"], refused("alias bomb"), None, 30
    yield "regression", "alias bomb as a train", ["solve", "--track", AMS, "--train", bomb, "--time", 80],\
        refused("alias bomb"), None, 30

    yield "runaway", "network leg 1e7 s", ["network", network(tmp, "n1e7", running_times_s=[1e7, 200, 120]),
                                           "--no-plot"], refused("running_times_s[0]", "would crawl"), None, 60
    yield "runaway", "controller sample time 1e-4 s", [
        "simulate", loop_study(tmp, "ts", sample_time_s=1e-4), "--no-progress", "--no-plot"], refused(), None, 120
    yield "runaway", "convex controller at 20 000 points", [
        "simulate", loop_study(tmp, "k20000", points=20000), "--no-progress", "--no-plot"], refused(), None, 300
    yield "runaway", "OSRD effort curve of 1e6 points", ["solve", "--track", AMS, "--train", osrd_curve(tmp, 10**6),
                                                         "--supplement", 10, "--out", o("osrd")],\
        refused("1,000,000 points", "--force"), None, 120
    yield "runaway", "1 % traction to the loop's cap", [
        "simulate", loop_study(tmp, "weak", deviations={"traction": {"low": 0.01, "high": 0.01}}), "--no-progress",
        "--no-plot"], refused("22,720 s"), None, 120
    yield "runaway", "pareto 10 000 points at K = 100 000", [
        "pareto", "--track", AMS, "--train", METRO, "--count", 10000, "--points", 100000, "--out", o("p"),
        "--no-plot"], refused("--force"), None, 120
    yield "runaway", "a sweep of 3 000 cases at K = 5 000", ["run", write(tmp / "sweep.yaml", {
        "name": "sweep", "track": str(AMS), "train": str(METRO), "points": 5000, "objective": "energy",
        "sweep": {"supplement_percent": [1 + 0.01 * i for i in range(3000)]}, "output": str(tmp / "out_sweep")}),
        "--no-progress"], refused("--force"), None, 120

    yield "silent", "empty stop name in a track", ["solve", "--track", track_with_stop_name(tmp, ""), "--train", METRO,
                                                   "--supplement", 10, "--out", o("e")], refused("empty name"), None, 60
    yield "silent", "journey --stops ''", ["journey", "--track", LINE4, "--train", METRO, "--stops", "", "--supplement",
                                           10, "--out", o("j")], refused("empty stop name"), None, 60
    for label, scenario, fragment in [("out of range", {"train_overrides": {"mass_t": 1e9}}, "mass_t"),
                                      ("unknown field", {"train_overrides": {"mas_t": 100}}, "unknown field"),
                                      ("NaN override", {"train_overrides": {"mass_t": float("nan")}}, "finite"),
                                      ("missing file", {"train": "nowhere.yaml"}, "file not found")]:
        yield "silent", f"solve STUDY with a scenario {label}", [
            "solve", study_scenario(tmp, label.replace(" ", "_"), scenario), "--out", o("s"), "--no-plot"],\
            refused(fragment), None, 60
    for label, controller in [("estimator on ato", {"name": "a", "kind": "ato", "estimator": True}),
                              ("block on convex", {"name": "c", "kind": "convex", "block": 20}),
                              ("omega on convex", {"name": "c", "kind": "convex", "omega": 3505}),
                              ("variant on convex", {"name": "c", "kind": "convex", "variant": "multi"})]:
        yield "silent", f"closed loop: {label}", [
            "simulate", loop_study(tmp, label.replace(" ", "_"), controllers=[controller]), "--no-progress",
            "--no-plot"], refused("controllers[0]"), None, 60
    yield "silent", "journey arrival window", [
        "journey", "--track", LINE4, "--train", METRO, "--timetable",
        STUDIES / "timetables" / "metro_line_4stops_Journey_01.json", "--dwell", 20, "--points", 150, "--no-plot",
        "--out", o("jw")], computed(journey_window_numbers), o("jw"), 600
    yield "silent", "pareto --count 20", ["pareto", "--track", AMS, "--train", METRO, "--count", 20, "--points", 150,
                                          "--no-plot", "--out", o("p20")], computed(front_rows(20)), o("p20"), 600
    yield "silent", "--no-plot lists no plot", ["solve", "--track", AMS, "--train", METRO, "--time", 80, "--points", 100,
                                                "--no-plot", "--out", o("np")], computed(no_plot_listed), o("np"), 120
    mc = loop_study(tmp, "only", controllers=[{"name": "convex", "kind": "convex"},
                                              {"name": "ato", "kind": "ato"}], points=100, draws=1)
    yield "silent", "aggregate.csv with --only", ["simulate", mc, "--only", "ato", "--no-progress", "--no-plot"],\
        computed(aggregate_no_empty), tmp / "out_only", 600
    yield "silent", "results.sqlite.lock after a run", ["run", write(tmp / "one.yaml", {
        "name": "one", "track": str(AMS), "train": str(METRO), "points": 60, "objective": "energy",
        "sweep": {"supplement_percent": [10]}, "output": str(tmp / "out_one")}), "--no-progress"],\
        computed(no_lock), tmp / "out_one", 120

    for edit, fragment in [("truncated", "rows where the run has"), ("nan", "'nan' is not a finite number"),
                           ("text", "'fast' is not a finite number")]:
        yield "internal", f"check on a {edit} profile", ["check", saved_profile(tmp, src, edit)], refused(fragment), \
            None, 120
    yield "internal", "library study with no cases", ["run", library(tmp), "--no-progress"],\
        refused("no case to run"), None, 120
    yield "internal", "text in a heavy-haul reference CSV", ["heavyhaul", heavyhaul_reference(tmp, "fast"),
                                                             "--no-progress", "--no-plot"],\
        refused("'fast' is not a finite number"), None, 180

    yield "unclear", "a train that cannot climb", ["solve", "--track", hill(tmp), "--train", weak_train(tmp, 0.05),
                                                   "--time", 200, "--out", o("climb"), "--no-plot"],\
        refused("cannot climb"), None, 120
    yield "unclear", "NaN in a heavy-haul reference", ["heavyhaul", heavyhaul_reference(tmp, "nan"), "--no-progress",
                                                       "--no-plot"], refused("'nan' is not a finite number"), None, 180
    yield "unclear", "a repeated stop", ["journey", "--track", LINE4, "--train", METRO, "--stops",
                                         "Noord,Station,Station", "--time", 200, "--out", o("rep")],\
        refused("straight after"), None, 60
    yield "unclear", "--das minlp --das-time-limit 5", [
        "solve", "--track", AMS, "--train", METRO, "--time", 80, "--points", 400, "--das", "minlp",
        "--das-time-limit", 5, "--no-plot", "--out", o("minlp")], computed(minlp_limit(5)), o("minlp"), 300

    for power in (1e6, 1e7):
        yield "valid data", f"TTOBench train at {power:g} kW", [
            "solve", "--track", DATA / "ttobench_track.json", "--train", ttobench_train(tmp, power), "--supplement", 10,
            "--points", 300, "--no-plot", "--out", o(f"tto{power:g}")], computed(tto_power), o(f"tto{power:g}"), 300


def run(src, argv, timeout):
    env = dict(os.environ, PYTHONPATH=str(src), PYTHONDONTWRITEBYTECODE="1")
    t0 = time.perf_counter()
    try:
        p = subprocess.run([sys.executable, "-m", "ecostudy", *map(str, argv)], capture_output=True, text=True,
                           timeout=timeout, env=env, cwd=src)
        code, output = p.returncode, p.stdout + p.stderr
    except subprocess.TimeoutExpired as exc:
        code, output = "timeout", (exc.stdout or b"").decode(errors="replace") if isinstance(exc.stdout, bytes) else ""
    return {"code": code, "output": output, "seconds": time.perf_counter() - t0}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--src", type=Path, default=ROOT)
    ap.add_argument("--only", action="append")
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="probe_"))
    rows = []
    for cls, name, argv, judge, out, timeout in probes(tmp, a.src):
        if a.only and cls not in a.only:
            continue
        r = run(a.src, argv, timeout)
        if r["code"] == "timeout":
            ok, why = False, f"no answer in {timeout} s"
        elif r["code"] == 3 or "Traceback" in r["output"]:
            ok, why = False, "internal error (exit 3)"
        else:
            ok, why = judge(r, out)
        first = next((x for x in r["output"].splitlines() if x.startswith("error:")), "")
        rows.append({"class": cls, "probe": name, "exit": r["code"], "seconds": round(r["seconds"], 1),
                     "pass": ok, "why": why, "error": first[:160]})
        print(f"{cls:11s} {'PASS' if ok else 'FAIL'} {str(r['code']):>7s} {r['seconds']:6.1f} s  {name}: {why}"
              + (f"\n{'':31s}{first[:150]}" if first else ""), flush=True)
    by = {}
    for row in rows:
        by.setdefault(row["class"], [0, 0])[0 if row["pass"] else 1] += 1
    print("by class: " + "; ".join(f"{c} {p} pass / {f} fail" for c, (p, f) in by.items()))
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1))
    return 0 if all(r["pass"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
