"""The text of ``sescid --version``, defined once (standard library only).

The ``sescid`` script (``_sescid_launch``, outside the package) runs this file on its own to
answer ``--version`` without loading numpy; the command line's ``--version`` prints the same.
"""

#: the text of ``sescid --version`` (click's ``%(prog)s``/``%(version)s`` placeholders)
VERSION_MESSAGE = "%(prog)s, version %(version)s"


def version_text() -> str | None:
    """``sescid --version``'s line from the installed distribution's metadata (as click reads
    it), or None where sescid is not installed (then the command line answers)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return VERSION_MESSAGE % {"prog": "sescid", "version": version("sescid")}
    except PackageNotFoundError:
        return None


__all__ = ["VERSION_MESSAGE", "version_text"]
