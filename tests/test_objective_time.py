"""The fastest run (objective 'time') keeps no running time: a study that gives both is refused, a
scenario or sweep that combines them runs the fastest run once, its running time left out with a
warning; a run read as keeping a running time it never kept was ok (71.7 s for 80 s asked)."""
import pandas as pd

from .test_bad_input_studies import hostile, nothing_written, refused, run


def test_a_study_asking_the_fastest_run_with_a_running_time_is_refused(tmp_path):
    study = hostile(tmp_path, "default.yaml", objective="time", points=50)
    refused(run("solve", study, "--no-plot"), f"{study}: running_time_s: objective 'time' finds the fastest run")
    refused(run("run", study, "--workers", 1), "running_time_s: objective 'time'")
    nothing_written(tmp_path)


def test_a_swept_fastest_run_is_run_once_without_the_running_times(tmp_path):
    study = hostile(tmp_path, "default.yaml", points=50, running_time_s=None,
                    sweep={"objective": ["energy", "time"], "running_time_s": [76, 80]})
    result = run("run", study, "--workers", 1)
    assert result.exit_code == 0, result.output
    assert "objective: scenario 'base': objective 'time' finds the fastest run: its running_time_s does not " \
           "apply (left out)" in result.output
    table = pd.read_csv(tmp_path / "out" / "results.csv")
    assert sorted(table["objective"]) == ["energy", "energy", "time"], table.to_string()
    fastest = table[table["objective"] == "time"].iloc[0]
    assert fastest["running_time_s"] == fastest["all_out_time_s"] < 76, table.to_string()


def test_the_fastest_run_of_a_timed_study_says_its_running_time_is_left_out(tmp_path):
    study = hostile(tmp_path, "default.yaml", points=50)
    result = run("solve", study, "--objective", "time", "--no-plot")
    assert result.exit_code == 0, result.output
    assert "running_time_s: does not apply to --objective time (the fastest run): left out" in result.output
