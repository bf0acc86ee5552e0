"""What a file given as a table is when it is not one: a fit, a truth, a sensor file, a model,
a mapping, binary data, a Parquet file under another name, a CSV split by semicolons — said in
one line instead of a parse error about its second row."""

from __future__ import annotations

from pathlib import Path

from sescid.errors import DataError

#: bytes looked at to tell a table from another kind of file
SNIFF_BYTES = 1 << 12


def refuse_other_content(path: Path) -> None:
    """DataError saying what a file given as a table is instead: Parquet under another name,
    binary data, JSON (a fit, a truth, a sensor file: named by its format), XML (a robot
    model), YAML; or a header of one column holding semicolons or tabs."""
    try:
        with path.open("rb") as fh:
            head = fh.read(SNIFF_BYTES)
    except OSError as exc:
        raise DataError(f"{path}: cannot read ({exc.strerror})") from None
    table = "give a CSV file with a header row, or a Parquet file"
    if head.startswith(b"PAR1"):
        raise DataError(f"{path}: a Parquet file without the .parquet name: rename it")
    text = head.decode("utf-8", errors="ignore").lstrip("\ufeff \t\r\n")
    if b"\x00" in head or _binary(head):
        raise DataError(f"{path}: binary data, not a table: {table}")
    if text.startswith(("{", "[")):
        raise DataError(f"{path}: {_json_kind(path)}, not a table: {table}")
    if text.startswith("<"):
        raise DataError(f"{path}: an XML file (a robot model?), not a table: {table}")
    first = text.split("\n", 1)[0]
    if first.startswith("---") or (":" in first and "," not in first):
        raise DataError(f"{path}: a YAML file (a mapping?), not a table: {table}")
    if "," not in first and (";" in first or "\t" in first):
        sep = "semicolons" if ";" in first else "tabs"
        raise DataError(
            f"{path}: the header is one column split by {sep}: sescid reads comma-separated "
            "files (save the table as CSV with commas)"
        )


def _binary(head: bytes) -> bool:
    """True for bytes that are not UTF-8 text (a character cut at the end is allowed)."""
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as exc:
        return exc.start < len(head) - 4
    return False


#: what a sescid JSON file is, by the name of its ``format`` (before the ``/version``); the
#: formats are ``FIT_FORMAT``, ``TRUTH_FORMAT``, ``FSR_FORMAT`` and ``PLATE_FORMAT`` of the
#: layers above (a test holds these names to them)
JSON_KINDS = {
    "sescid-fit": "a fit (sescid identify --out)",
    "sescid-experiment-truth": "an experiment's truth (sescid experiment --truth)",
    "sescid-fsr": "a foot-sensor file (--sensors)",
    "sescid-plate": "a force-plate file",
}


def _json_kind(path: Path) -> str:
    """What a JSON file is, by its ``format`` field: 'a fit (…)' or 'a JSON file'."""
    import json

    try:
        with path.open(encoding="utf-8") as fh:
            doc = json.load(fh)
    except (OSError, ValueError):
        return "a JSON file"
    fmt = doc.get("format") if isinstance(doc, dict) else None
    name = str(fmt).split("/")[0] if fmt is not None else ""
    if name in JSON_KINDS:
        return f"{JSON_KINDS[name]}, format {fmt}"
    return f"a JSON file (format {fmt})" if fmt is not None else "a JSON file"
