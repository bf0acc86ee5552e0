"""An XML model file read and written back with the standard library (``xml.etree``), so that
export needs no extra package: comments and processing instructions inside the root, element
order, attribute order and namespace prefixes survive; what lies around the root element (the
XML declaration, comments, a DOCTYPE) is kept as text. Attributes are re-serialised with double
quotes (the values, not their spelling, are what a parser reads).
"""

from __future__ import annotations

import re
import xml.parsers.expat
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree as ET

from sescid.base.files import atomic_path
from sescid.errors import ModelError

_DECL = re.compile(rb"^\s*<\?xml[^>]*\?>", re.S)
_ENCODING = re.compile(rb"""encoding\s*=\s*["']([A-Za-z0-9._-]+)["']""")


@dataclass
class XmlDoc:
    """A parsed XML file: its root element and the text around it."""

    path: Path
    root: ET.Element
    prolog: str  #: text before the root element, without the XML declaration
    epilog: str  #: text after the root element
    declared: bool  #: the file starts with an XML declaration
    namespaces: dict[str, str]  #: prefix → URI, as declared in the file


def _root_span(data: bytes) -> tuple[int, int]:
    """Byte offsets of the root element's start tag and of the end of its end tag."""
    parser = xml.parsers.expat.ParserCreate()
    span = [-1, -1]
    depth = [0]

    def start(name, attrs):
        if depth[0] == 0 and span[0] < 0:
            span[0] = parser.CurrentByteIndex
        depth[0] += 1

    def end(name):
        depth[0] -= 1
        if depth[0] == 0:
            span[1] = parser.CurrentByteIndex

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.Parse(data, True)
    return span[0], data.index(b">", span[1]) + 1


def read_xml(path: str | Path, what: str) -> XmlDoc:
    """Parse ``path`` keeping comments; ModelError (one line naming the file) when it cannot be
    read. ``what``: the file's kind for messages ("URDF", "MJCF")."""
    path = Path(path)
    try:
        data = path.read_bytes()
        namespaces: dict[str, str] = {}
        for _, (prefix, uri) in ET.iterparse(path, events=("start-ns",)):
            namespaces.setdefault(prefix, uri)
        builder = ET.TreeBuilder(insert_comments=True, insert_pis=True)
        parser = ET.XMLParser(target=builder)
        parser.feed(data)
        root = parser.close()
        start, end = _root_span(data)
    except (OSError, ET.ParseError, xml.parsers.expat.ExpatError, ValueError) as exc:
        raise ModelError(f"{path}: cannot read the {what} to export ({exc})") from None
    m = _ENCODING.search(data[:200])
    encoding = m.group(1).decode() if m and _DECL.match(data) else "utf-8"
    prolog = _DECL.sub(b"", data[:start], count=1).decode(encoding)
    declared = _DECL.match(data) is not None
    prolog = prolog.lstrip("\n") if declared else prolog
    epilog = data[end:].decode(encoding)
    return XmlDoc(path, root, prolog, epilog, declared=declared, namespaces=namespaces)


def _prefixed(root: ET.Element, namespaces: dict[str, str]) -> None:
    """Turn '{uri}name' tags and attributes back into the file's 'prefix:name' (in place) and
    declare the prefixes on the root."""
    if not namespaces:
        return
    by_uri = {uri: prefix for prefix, uri in namespaces.items()}

    def name(qname: str) -> str:
        if not qname.startswith("{"):
            return qname
        uri, local = qname[1:].split("}", 1)
        prefix = by_uri.get(uri)
        if prefix is None:
            return qname
        return f"{prefix}:{local}" if prefix else local

    for el in root.iter():
        if isinstance(el.tag, str):
            el.tag = name(el.tag)
        for key in [k for k in el.attrib if k.startswith("{")]:
            el.attrib[name(key)] = el.attrib.pop(key)
    for prefix, uri in namespaces.items():
        root.set(f"xmlns:{prefix}" if prefix else "xmlns", uri)


_COMMENT_OR_PI = re.compile(r"(<!--.*?-->|<\?.*?\?>)", re.S)


def _tight(text: str) -> str:
    """'<a />' → '<a/>' (as most model files are written) outside comments and PIs: text and
    attribute values hold no literal '>' (escaped), so what remains are tags."""
    parts = _COMMENT_OR_PI.split(text)
    return "".join(p if k % 2 else p.replace(" />", "/>") for k, p in enumerate(parts))


def write_xml(doc: XmlDoc, path: str | Path) -> None:
    """Write ``doc`` to ``path`` atomically, UTF-8 (an XML declaration if the source had one)."""
    _prefixed(doc.root, doc.namespaces)
    body = _tight(ET.tostring(doc.root, encoding="unicode", short_empty_elements=True))
    head = '<?xml version="1.0" encoding="utf-8"?>\n' if doc.declared else ""
    text = head + doc.prolog + body + doc.epilog
    if not text.endswith("\n"):
        text += "\n"
    with atomic_path(Path(path)) as tmp:
        tmp.write_bytes(text.encode("utf-8"))


def add_note(root: ET.Element, text: str) -> None:
    """A comment as the root's first child, indented like the root's first child."""
    note = ET.Comment(f" {text} ")
    indent = root.text if root.text and not root.text.strip() else "\n  "
    note.tail = indent
    root.insert(0, note)
    root.text = indent


def new_child(parent: ET.Element, tag: str, first: bool = False) -> ET.Element:
    """A new ``tag`` element in ``parent`` (first or last child), indented like its siblings."""
    el = ET.Element(tag)
    indent = parent.text if parent.text and not parent.text.strip() else None
    if first or len(parent) == 0:
        el.tail = indent if len(parent) else None
        parent.insert(0, el)
    else:
        last = parent[-1]
        el.tail, last.tail = last.tail, indent if indent is not None else last.tail
        parent.append(el)
    return el
