"""The frozen Fit and what is read off it: its file, notes and summary (made outside the
record), identifiability, validation and the CAD check."""

#: the sub-package's modules (imported where used: no import here)
__all__ = [
    "cad_check",
    "fit",
    "fit_json",
    "records",
    "identifiability",
    "notes",
    "payload_record",
    "summary",
    "tilt",
    "validation",
]
