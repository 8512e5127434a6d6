"""Diagnosis: where simulation and recording differ, which left-out physics explains it, and
what remains unexplained.

``Diagnoser(design, mode).fit(recording).diagnosis_`` (see ``estimator`` for the chain);
``report`` writes the JSON contract, the figures, ``report.html`` and the updated design.
"""
from .estimator import Diagnoser, Diagnosis, DiagnosisError, zeta_d
from .residual import ljung_box_p
from .report import plot_diagnosis, updated_design, write_diagnosis, write_report

__all__ = ["Diagnoser", "Diagnosis", "DiagnosisError", "zeta_d", "ljung_box_p",
           "plot_diagnosis", "updated_design", "write_diagnosis", "write_report"]
