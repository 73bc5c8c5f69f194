"""Where `ecostudy solve` spends its time, stage by stage, from the process's start to its exit.

    .venv/bin/python bench/bench_startup.py [--study studies/default.yaml] [--repeat 5] [--no-plot]

Runs the command ``--repeat`` times, each in a fresh process that is the ``ecostudy`` command with
stamps added (wall seconds since the process started, from /proc, and this process's CPU seconds,
``time.process_time``) after each stage: the interpreter, the command line's import, the parsing,
the solve chain's import, the study's load, the figure process's fork, build + NL write + Ipopt,
tables and verification, profile.csv, the wait for the figures, summary.json and report.html,
the figure process's exit, the rest. Prints a markdown table of the medians (wall and CPU seconds
per stage; the figure process's own CPU is not in them: time the whole command for that, e.g.
``/usr/bin/time -v``). The stamps wrap ecostudy's own functions; the command is otherwise the
same.
"""
import argparse
import functools
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

GROUPS = [("interpreter start", ["interpreter"]),
          ("import the command line (Typer, rich) and ecostudy.api", ["cli", "api"]),
          ("parse the command (Typer loads pydantic here)", ["parse"]),
          ("import the solve chain (Pyomo, SciPy, pandas, cyipopt, schemas)", ["chain"]),
          ("load and check the study", ["study", "out_dir"]),
          ("fork the figure process", ["fork"]),
          ("grid and guesses", ["prepare"]),
          ("build, NL write, Ipopt", ["solve"]),
          ("tables, regimes, verification", ["finish"]),
          ("send the figures, profile.csv", ["submit", "profile.csv"]),
          ("wait for the figures", ["figures"]),
          ("summary.json, report.html", ["summary.json", "stale", "report.html"]),
          ("the figure process's exit", ["child_exit"]),
          ("inputs.json, read back, print, exit", ["inputs.json", "read_back", "leave"])]


def one(out_file, argv):
    """The ``ecostudy`` command with stamps; they go to ``out_file`` as one JSON line at its exit."""
    with open("/proc/self/stat") as f:
        start = int(f.read().rsplit(")", 1)[1].split()[19]) / os.sysconf("SC_CLK_TCK")
    offset = time.clock_gettime(time.CLOCK_BOOTTIME) - start - time.perf_counter()
    stamps = []

    def stamp(label):
        stamps.append((label, time.perf_counter() + offset, time.process_time()))

    def wrap(module, name, label):
        f = getattr(module, name)

        @functools.wraps(f)
        def stamped(*a, **k):
            value = f(*a, **k)
            stamp(label)
            return value
        setattr(module, name, stamped)

    stamp("interpreter")
    import ecostudy.cli  # noqa: F401
    stamp("cli")
    app = sys.modules["ecostudy.cli.app"]
    import ecostudy.api as api
    stamp("api")
    resolve = api.__getattr__

    def resolved(name):
        stamp("parse")
        value = resolve(name)
        stamp("chain")
        import ecostudy.analysis.single as single
        import ecostudy.api.single as command
        import ecostudy.report.drawer as drawer
        import ecostudy.report.files as files
        for module, name_, label in [(command, "load_checked_study", "study"), (command, "check_output_dir", "out_dir"),
                                     (single, "prepare", "prepare"), (single, "solve_once", "solve"),
                                     (single, "finish", "finish"), (files, "write_csv", "profile.csv"),
                                     (files, "write_summary", "summary.json"), (files, "stale", "stale"),
                                     (files, "write_html", "report.html"), (command, "write_json", "inputs.json"),
                                     (command, "reported", "read_back")]:
            wrap(module, name_, label)
        init, close, meanwhile = drawer.Drawer.__init__, drawer.Drawer.close, files.figures_meanwhile

        def started(self, *a):
            init(self, *a)
            stamp("fork")

        def closed(self):
            close(self)
            stamp("child_exit")

        def sent(*a, **k):
            drawn = meanwhile(*a, **k)
            stamp("submit")

            def waited():
                names = drawn()
                stamp("figures")
                return names
            return waited
        drawer.Drawer.__init__, drawer.Drawer.close, files.figures_meanwhile = started, closed, sent
        return value
    api.__getattr__ = resolved
    leave = app.leave

    def stamped_leave(code):
        stamp("leave")
        with open(out_file, "a") as f:
            f.write(json.dumps(stamps) + "\n")
        leave(code)
    app.leave = stamped_leave
    sys.argv = ["ecostudy", *argv]
    app.main()


def table(lines):
    """Markdown rows: the median wall and CPU seconds of each stage group, and of the whole process."""
    runs = []
    for line in lines:
        stamps, prev, stages = json.loads(line), (0.0, 0.0), {}
        for label, wall, cpu in stamps:
            stages[label] = (wall - prev[0], cpu - prev[1])
            prev = (wall, cpu)
        runs.append((stages, stamps[-1][1], stamps[-1][2]))
    rows = ["| stage | wall s | CPU s |", "|---|---:|---:|"]
    for name, labels in GROUPS:
        seen = [r for r, _, _ in runs if any(label in r for label in labels)]
        if seen:
            wall = statistics.median(sum(r[k][0] for k in labels if k in r) for r in seen)
            cpu = statistics.median(sum(r[k][1] for k in labels if k in r) for r in seen)
            rows.append(f"| {name} | {wall:.2f} | {cpu:.2f} |")
    rows.append(f"| **whole command (this process)** | **{statistics.median(w for _, w, _ in runs):.2f}** | "
                f"**{statistics.median(c for _, _, c in runs):.2f}** |")
    return "\n".join(rows)


def main():
    if sys.argv[1:2] == ["--one"]:
        return one(sys.argv[2], sys.argv[3:])
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--study", default=str(ROOT / "studies" / "default.yaml"))
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--no-plot", action="store_true")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "stamps.jsonl"
        command = ["solve", args.study, "--out", str(Path(tmp) / "run")] + (["--no-plot"] if args.no_plot else [])
        for _ in range(args.repeat):
            subprocess.run([sys.executable, __file__, "--one", str(out), *command], check=True,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        print(f"`python bench/bench_startup.py --repeat {args.repeat}{' --no-plot' if args.no_plot else ''}`, "
              f"medians of {args.repeat} runs:\n")
        print(table(out.read_text().splitlines()))


if __name__ == "__main__":
    main()
