"""Every built-in study kind, registered on :data:`ecostudy.studies.batch.STUDY_KINDS` by importing
this module: ``run`` (:mod:`~ecostudy.studies.batch`), ``compare`` (:mod:`~ecostudy.studies.compare`), ``network``
(:mod:`~ecostudy.studies.network`), ``pareto`` (:mod:`~ecostudy.studies.front`), ``heavyhaul`` (:mod:`~ecostudy.studies.heavyhaul`), ``simulate`` (:mod:`~ecostudy.studies.loopkind`)."""
from ecostudy.studies import batch, compare, front, heavyhaul, loopkind, network  # noqa: F401  (each registers its kind)
from ecostudy.studies.batch import STUDY_KINDS

__all__ = ["STUDY_KINDS"]
