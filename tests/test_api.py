"""The README's Python API example runs as written, and its results are the CLI's."""
import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def readme_example():
    text = (ROOT / "README.md").read_text()
    section = text[text.index("## Python API"):]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


@pytest.mark.slow  # over 7 s: make test stays under 3 min; CI runs it
def test_the_readme_example_runs(capsys):
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        scope = {}
        exec(compile(readme_example(), "README.md (Python API)", "exec"), scope)
    finally:
        os.chdir(cwd)
    run, front, plan, table = scope["run"], scope["front"], scope["plan"], scope["table"]
    assert run.verification["passed"] and run.summary["running_time_s"] == pytest.approx(80.0)
    assert table["speed_mps"].to_numpy() * 3.6 == pytest.approx(table["speed_kmh"].to_numpy(), rel=1e-9)
    assert scope["fig"].axes  # a figure with its panels
    assert len(front.table) >= 6 and front.table["traction_energy_kWh"].is_monotonic_decreasing
    assert plan.outcome.optimal and plan.time[-1] == pytest.approx(80.0, abs=1e-6)
    assert 0 < plan.traction_energy < run.trajectory.ft @ (run.trajectory.nodes[1:] - run.trajectory.nodes[:-1])
    assert "kWh still to spend" in capsys.readouterr().out


def test_inputs_built_in_code_are_checked_like_files():
    from ecostudy import api
    from ecostudy.core.errors import InputError
    with pytest.raises(InputError, match=r"track \(in code\): length_m"):
        api.track_from_dict({"name": "x", "length_m": -5, "stops": [], "gradients": [], "speed_limits": []})
    train = api.load_train(ROOT / "trains/amsterdam_metro.yaml")
    track = api.load_track(ROOT / "tracks/amsterdam_rokin_centraal.yaml")
    with pytest.raises(InputError, match="running_time/supplement_percent/window: give one of them"):
        api.solve(track, train, running_time=80.0, supplement_percent=5.0)
    with pytest.raises(InputError, match="unknown stop"):
        api.solve(track, train, "Nowhere", running_time=80.0)
