"""Model export: the fit's model file (URDF or MJCF) with identified masses and CoMs,
everything else as in the source (``export_model`` picks the writer by the fit's model format).

Modules: ``xmldoc`` (XML read and written with the standard library), ``inertia`` (what an
inertial gets: merged parts, valid tensors, mass warnings), ``assets`` (MJCF includes resolved,
relative asset paths rewritten), ``parts`` (every link's exported inertial, format-free),
``urdf``, ``mjcf``, ``usd`` (a UsdPhysics layer), ``model`` (the dispatch).
"""

from sescid.io.export.mjcf import export_mjcf
from sescid.io.export.model import FORMATS, export_model
from sescid.io.export.parts import Part, exported_parts
from sescid.io.export.urdf import export_urdf
from sescid.io.export.usd import USD_SUFFIXES, export_usd

__all__ = [
    "FORMATS",
    "USD_SUFFIXES",
    "Part",
    "export_mjcf",
    "export_model",
    "export_urdf",
    "export_usd",
    "exported_parts",
]
