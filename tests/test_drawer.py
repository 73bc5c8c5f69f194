"""Figures drawn in a forked child while the parent solves (``report.drawer``): every file exists
and the child has ended when the command returns; the child's failure is the command's failure
(same one line and exit status as a figure drawn in the parent); data that cannot be pickled is
drawn in the parent."""
import json
import multiprocessing
import operator
import os
import signal
import time

import pytest

from ecostudy import api
from ecostudy.core.deadline import can_fork
from ecostudy.io.writers import atomic_write
from ecostudy.report import drawer as drawer_module
from ecostudy.report.drawer import Drawer, FigureError, apart, drawing

from .conftest import ROOT

pytestmark = pytest.mark.skipif(not can_fork(), reason="no fork start method here")
DEFAULT = ROOT / "studies" / "default.yaml"


def test_a_solve_with_figures_returns_with_every_file_written_and_the_child_ended(tmp_path):
    report = api.solve_folder(DEFAULT, points=150, out=tmp_path / "s")
    assert multiprocessing.active_children() == []
    summary = json.loads((tmp_path / "s" / "summary.json").read_text())
    assert summary["status"] == "ok" and report.status.ok
    for name in ("speed.png", "energy.png", "profile.csv", "report.html", "inputs.json"):
        assert (tmp_path / "s" / name).stat().st_size > 0, name
    assert {"speed.png", "energy.png", "inputs.json"} <= set(summary["files"])  # every file it wrote, listed
    assert (tmp_path / "s" / "speed.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "data:image/png;base64," in (tmp_path / "s" / "report.html").read_text()


def test_the_figures_are_the_same_drawn_in_the_child_or_here(tmp_path, monkeypatch):
    api.solve_folder(DEFAULT, points=150, out=tmp_path / "child")
    monkeypatch.setattr(drawer_module, "can_fork", lambda: False)  # as where fork is missing: drawn here
    api.solve_folder(DEFAULT, points=150, out=tmp_path / "here")
    for name in ("speed.png", "energy.png", "profile.csv"):
        assert (tmp_path / "child" / name).read_bytes() == (tmp_path / "here" / name).read_bytes(), name


class Blocking:
    """A watcher of the solve that puts a folder where ``energy.png`` goes once the run is solved:
    after the output folder was checked, before the figure is written."""

    def __init__(self, out):
        self.out = out

    def stage(self, name, total=None, unit=""):
        if name == "figures and files":
            (self.out / "energy.png").mkdir(parents=True)

    def step(self, done, note=""):
        pass


def test_a_folder_put_where_a_figure_goes_while_the_run_solves_is_refused_before_any_file(tmp_path):
    out = tmp_path / "s"
    with pytest.raises(api.InputError, match=f"^{out / 'energy.png'}: is a folder where an output file goes$"):
        api.solve_folder(DEFAULT, points=150, out=out, progress=Blocking(out))  # the command line: exit status 2
    assert sorted(p.name for p in out.iterdir()) == ["energy.png"]  # the run's files are checked before any is written
    assert multiprocessing.active_children() == []


def test_a_child_whose_parent_stopped_waiting_ends_without_a_traceback(capfd):
    """A parent whose own write failed closes the figure process before it answers: the child's
    answer finds the pipe closed, and it ends quietly (a BrokenPipeError traceback was printed)."""
    with drawing(True) as drawer:
        assert isinstance(drawer, Drawer)
        drawer.submit(time.sleep, 0.5)  # its answer is never waited for
    assert drawer.process.exitcode == 0
    assert "Traceback" not in capfd.readouterr().err


def test_the_childs_error_is_raised_here_with_its_type_and_traceback():
    with drawing(True) as drawer:
        assert isinstance(drawer, Drawer)
        wait = drawer.submit(int, "not a number")
        with pytest.raises(ValueError, match="invalid literal") as raised:
            wait()
        assert "in the figure process" in "\n".join(raised.value.__notes__)
        assert drawer.submit(sorted, [3, 1, 2])() == [1, 2, 3]  # the child serves on after an error
    assert not drawer.process.is_alive() and drawer.process.exitcode == 0


def test_a_child_that_dies_is_a_figure_error_naming_its_exit_code():
    with drawing(True) as drawer:
        wait = drawer.submit(os._exit, 7)
        with pytest.raises(FigureError, match="exit code 7"):
            wait()
        with pytest.raises(FigureError, match="ended"):
            drawer.submit(sorted, [1])()


def test_work_that_cannot_be_pickled_is_done_here_and_no_plot_forks_nothing():
    with drawing(True) as drawer:
        assert drawer is not None
        assert drawer.submit(lambda x: x + 1, 1)() == 2
    with drawing(False) as nothing:
        assert nothing is None


def test_the_figure_process_runs_each_job_in_a_fork_and_raises_the_forks_error_with_its_type():
    with drawing(True) as drawer:
        assert drawer.submit(apart, int, [("1",), ("2",), ("3",)])() == [1, 2, 3]  # in the order given
        with pytest.raises(ValueError, match="invalid literal") as raised:
            drawer.submit(apart, int, [("1",), ("not a number",)])()
        assert "in a figure's process" in "\n".join(raised.value.__notes__)
        with pytest.raises(FigureError, match=r"a figure's process ended \(exit code 5\)"):
            drawer.submit(apart, operator.call, [(sorted, [2, 1]), (os._exit, 5)])()
        assert drawer.submit(sorted, [3, 1, 2])() == [1, 2, 3]  # the figure process serves on, no fork left
    assert not drawer.process.is_alive() and drawer.process.exitcode == 0


def test_outside_the_figure_process_the_jobs_run_here_one_after_the_other():
    assert apart(os.getpid, [(), ()]) == [os.getpid(), os.getpid()]


def _slow_write(path):
    """A figure written as every figure is (``atomic_write``), slowly: its temporary file stands
    beside its name until the process is stopped."""
    def write(tmp):
        with open(tmp, "wb") as file:
            file.write(b"\x89PNG half a figure")
        time.sleep(60)
    atomic_write(path, write)


def test_a_figure_process_stopped_by_sigterm_leaves_no_temporary_file(tmp_path):
    """A `kill` of the command's process group reached the figure process while it wrote: it ended at
    once (SIGTERM's default) and left `.speed.png<random>.tmp` in the output folder. It now ends
    through Python, and the write's clean-up removes the file."""
    figure = tmp_path / "speed.png"
    drawer = Drawer()
    try:
        drawer.submit(_slow_write, figure)
        deadline = time.time() + 30
        while not list(tmp_path.glob(".speed.png*.tmp")) and time.time() < deadline:
            time.sleep(0.02)
        assert list(tmp_path.glob(".speed.png*.tmp")), "the slow write never started"
        os.kill(drawer.process.pid, signal.SIGTERM)
        drawer.process.join(10)
        assert drawer.process.exitcode == 128 + signal.SIGTERM
        assert list(tmp_path.iterdir()) == []
    finally:
        drawer.close()
