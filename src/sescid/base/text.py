"""Long lists in one printed line: the count, the first few items, and where the rest is.

Every message naming a list that can be long (a humanoid's 20 finger links, 80 constraints,
combinations of many terms) goes through ``listed``, so that a warning stays a line a reader
can take in, and says where the whole list is written.
"""

from __future__ import annotations

from collections.abc import Iterable

#: items shown before "… (and K more)"
FIRST = 3
#: characters of one item shown before it is cut with "…"
ITEM_CHARS = 80


def clipped(text: str, chars: int = ITEM_CHARS) -> str:
    """``text``, cut at a word boundary to at most ``chars`` characters and ended by " …"."""
    if len(text) <= chars:
        return text
    cut = text[: chars - 2].rsplit(" ", 1)[0]
    return f"{cut} …"


def listed(
    items: Iterable[str],
    *,
    first: int = FIRST,
    sep: str = ", ",
    where: str | None = None,
    chars: int = ITEM_CHARS,
) -> str:
    """The first ``first`` items joined by ``sep`` (each ``clipped`` to ``chars``), then
    " (and K more[: where])" when there are more; ``where`` says where the whole list is (e.g.
    "all in fit.json's weak"), also named when an item was cut."""
    all_items = [str(i) for i in items]
    shown = [clipped(i, chars) for i in all_items[:first]]
    text = sep.join(shown)
    rest = len(all_items) - len(shown)
    cut = any(a != s for a, s in zip(all_items, shown, strict=False))
    if rest > 0:
        text += f" (and {rest} more{'; ' + where if where else ''})"
    elif cut and where:
        text += f" ({where})"
    return text
