"""Model export: the fit's model file (URDF or MJCF) with identified masses and CoMs, everything
else untouched (``export_model`` picks the writer by the fit's model format)."""

from __future__ import annotations

from sescid.io.export.mjcf import export_mjcf
from sescid.io.export.urdf import FORMATS, export_model, export_urdf

__all__ = ["FORMATS", "export_mjcf", "export_model", "export_urdf"]
