"""Audit and compare: which candidate model file is the robot, and what changed between fits.

- ``audit(data, models, …)`` (``AuditOptions``) → ``AuditResult``: each candidate's mass gap,
  prediction and cross-validated errors per kind, the bodies the data reject, the model checks,
  a ranking;
- ``compare(fits, …)`` → ``CompareResult``: the bodies that changed between two fits beyond their
  uncertainty, the CoM and mass change; for several fits, outlier sessions and repeatability;
- ``model_checks(robot)``: what a model file gets wrong by itself, named by body.
"""

from sescid.audit.audit import DEFAULT_FOLDS, DEFAULT_Z, AuditOptions, audit
from sescid.audit.checks import Check, model_checks
from sescid.audit.compare import CompareResult, Repeat, Session, compare
from sescid.audit.result import AuditResult, BodyChange, CandidateAudit, KindError

__all__ = [
    "DEFAULT_FOLDS",
    "DEFAULT_Z",
    "AuditOptions",
    "AuditResult",
    "BodyChange",
    "CandidateAudit",
    "Check",
    "CompareResult",
    "KindError",
    "Repeat",
    "Session",
    "audit",
    "compare",
    "model_checks",
]
