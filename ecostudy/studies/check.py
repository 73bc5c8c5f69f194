"""`ecostudy check`: the Pontryagin check of a saved result, as its own optimum or for another time."""
from ecostudy.analysis.pontryagin import check_profile
from ecostudy.io.loaders import load_track, load_train
from ecostudy.io.results import load_result


def check_result(result_dir, running_time=None):
    """:func:`check_profile` of an `ecostudy solve` output folder (inputs.json, summary.json, profile.csv).

    A net-energy run is checked against eq. 7.4; energy and all-out runs against eq. 2.17.
    """
    saved = load_result(result_dir)
    inputs = saved.inputs
    objective = "net_energy" if saved.summary.get("objective") == "net_energy" else "energy"
    return check_profile(load_track(inputs["track"]), load_train(inputs["train"]), inputs, saved.trajectory,
                         running_time, objective=objective)[0]
