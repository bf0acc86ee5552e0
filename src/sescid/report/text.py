"""How sescid writes numbers (the report's page and the command line's lines) and the report's
tables: one home for units, "not determined" and escaping.

Lengths are shown in mm, torques in N·m, masses in kg; a quantity the data do not determine
(nan) is written "not determined", never 0 or ±0.
"""

from __future__ import annotations

import html
import math
from collections.abc import Iterable, Sequence

#: the words for a nan quantity, everywhere in the page
NOT_DETERMINED = "not determined"
#: the measurement kinds' names and display units (m shown as mm)
KIND_TITLES = {"cop": "CoP", "tau": "joint torques"}
SHOWN_UNIT = {"m": "mm", "N·m": "N·m"}

#: how the residual statistics are defined, said once in the page
RESIDUAL_DEFINITION = (
    "Residual = measured − predicted, per row of each kind: one CoP component (x or y) of one "
    "pose, in mm, or one joint's torque at one pose, in N·m; RMS = √(mean of squared residuals) "
    "and MAE = mean of absolute residuals over those rows. The identified model's residuals "
    "are net of the sensor offsets and friction bands it estimated (where determined)."
)

esc = html.escape


def finite(x: float | None) -> bool:
    """True for a real number (not None, nan or ±inf)."""
    return x is not None and math.isfinite(x)


def fixed(x: float, digits: int) -> str:
    """``x`` with ``digits`` decimals; a value that rounds to zero is written without a sign
    (never "-0.000")."""
    text = f"{x:.{digits}f}"
    return text[1:] if text.startswith("-") and float(text) == 0 else text


def in_mm(x: float | None, digits: int = 2) -> str:
    """A length in m written in mm, without the unit; "not determined" for nan."""
    return fixed(x * 1e3, digits) if finite(x) else NOT_DETERMINED  # type: ignore[operator]


def nm(x: float | None, digits: int = 3) -> str:
    """A torque in N·m; "not determined" for nan."""
    return fixed(x, digits) if finite(x) else NOT_DETERMINED  # type: ignore[arg-type]


def kg(x: float | None, digits: int = 4) -> str:
    """A mass in kg; "not determined" for nan."""
    return fixed(x, digits) if finite(x) else NOT_DETERMINED  # type: ignore[arg-type]


def percent(x: float | None, digits: int = 1) -> str:
    """A relative change (0.05 → "+5.0"); "–" when undefined (a zero reference)."""
    if not finite(x):
        return "–"
    text = fixed(x * 100, digits)  # type: ignore[operator]
    return text if text.startswith("-") or float(text) == 0 else "+" + text


def in_unit(x: float | None, unit: str, digits: int | None = None) -> str:
    """A value of a kind's unit ("m" or "N·m") in its display unit, without the unit."""
    if unit == "m":
        return in_mm(x, 3 if digits is None else digits)
    return nm(x, 4 if digits is None else digits)


def with_unit(x: float | None, unit: str) -> str:
    """``in_unit`` followed by the display unit (nothing after "not determined")."""
    text = in_unit(x, unit)
    return text if text == NOT_DETERMINED else f"{text} {SHOWN_UNIT.get(unit, unit)}"


def mm(x: float | None) -> str:
    """A length in m as "1.234 mm" (three decimals); "not determined" for nan or None."""
    return with_unit(x, "m")


def table(head: Sequence[str], rows: Iterable[Sequence[str]], align: str = "") -> str:
    """An HTML table; cells are HTML already (escape text with ``esc``). ``align``: one letter
    per column, "l" (text) or "r" (numbers); default: the first column left, the rest right."""

    def td(k: int, c: str, tag: str = "td") -> str:
        left = align[k] == "l" if k < len(align) else k == 0
        return f'<{tag} class="l">{c}</{tag}>' if left else f"<{tag}>{c}</{tag}>"

    th = "".join(td(k, h, "th") for k, h in enumerate(head))
    body = "".join("<tr>" + "".join(td(k, c) for k, c in enumerate(r)) + "</tr>" for r in rows)
    return f"<table><tr>{th}</tr>{body}</table>"


def cell(text: str) -> str:
    """A table cell's text, escaped, with "not determined" marked for the page's style."""
    if text == NOT_DETERMINED:
        return f'<span class="nd">{NOT_DETERMINED}</span>'
    return esc(text)
