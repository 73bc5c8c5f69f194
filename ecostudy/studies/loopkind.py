"""The closed-loop study as a registered study kind (``simulate``): every controller x every Monte
Carlo draw a case (:mod:`ecostudy.studies.closedloop`), refused before anything runs when a run
cannot end or the study is too big (:func:`ecostudy.studies.sizes.check_closed_loop_study`), so that
``ecostudy run FILE --kind simulate`` runs it like ``ecostudy simulate FILE`` (without the
figures), into the same store."""
from ecostudy.studies.batch import STUDY_KINDS, StudyKind
from ecostudy.studies.closedloop import expand_simulate, loop_table, run_loop_case
from ecostudy.studies.sizes import check_closed_loop_study


def simulate_size(where, cases, workers=1):
    """Refuse a closed-loop study whose runs cannot end, or estimated above the command's budget."""
    check_closed_loop_study(where, workers)


STUDY_KINDS.register("simulate", StudyKind(expand_simulate, run_loop_case, loop_table, simulate_size,
                                           table_file="runs.csv", table_name="runs"),
                     doc="controllers in the loop x Monte Carlo draws of the plant (Yazhemsky 2017; Farooqi 2018)")
