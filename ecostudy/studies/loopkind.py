"""The closed-loop study as a registered study kind (``simulate``): every controller x every Monte
Carlo draw a case (:mod:`ecostudy.studies.closedloop`), so that ``ecostudy run FILE --kind
simulate`` runs it like ``ecostudy simulate FILE``, into the same store and with the same files."""
from dataclasses import replace

from ecostudy.studies.batch import STUDY_KINDS
from ecostudy.studies.closedloop import SIMULATE, expand_simulate
from ecostudy.studies.sizes import check_closed_loop_study
from ecostudy.studies.workers import every_core


def expand_loop(path, out=None):
    """A closed-loop study file's cases, refused first (unless forced) when a run cannot end or the
    study is too big for every core (:func:`~ecostudy.studies.sizes.check_closed_loop_study`: the
    file's own numbers before the expansion solves anything)."""
    check_closed_loop_study(path, every_core(None), out=out)
    return expand_simulate(path, out)


STUDY_KINDS.register("simulate", replace(SIMULATE, expand=expand_loop, expand_into=expand_loop),
                     doc="controllers in the loop x Monte Carlo draws of the plant (Yazhemsky 2017; Farooqi 2018)")
