"""The files a model refers to: MJCF ``<include>`` resolved into one file, and relative asset
paths (meshes, textures, height fields, skins) rewritten so that they resolve from the folder
the export is written to.

MuJoCo looks for an included file relative to the main model's folder, then (nested includes)
relative to the including file's; the included file's top-level element is dropped and its
children take the ``<include>``'s place. Mesh, height-field and skin files are relative to
``compiler meshdir`` (else ``assetdir``, else the model's folder), textures to ``texturedir``
(else ``assetdir``): a relative directory attribute is rewritten, else each relative file
name. URDF ``<mesh filename>``/``<texture filename>`` that are relative paths (or relative
``file://`` URIs) are rewritten; ``package://`` URIs and absolute paths are left alone.
"""

from __future__ import annotations

import os
from pathlib import Path
from xml.etree import ElementTree as ET

from sescid.errors import ModelError
from sescid.io.export.xmldoc import read_xml

#: MJCF asset elements → (their file attributes, the compiler directory they are relative to)
MJCF_FILES = {
    "mesh": (("file",), "meshdir"),
    "hfield": (("file",), "meshdir"),
    "skin": (("file",), "meshdir"),
    "texture": (
        ("file", "fileright", "fileleft", "fileup", "filedown", "filefront", "fileback"),
        "texturedir",
    ),
    "model": (("file",), None),
}
_MAX_DEPTH = 32


def relative(target: Path, folder: Path) -> str:
    """``target`` as a POSIX path relative to ``folder`` (absolute when on another drive)."""
    try:
        return Path(os.path.relpath(target, folder)).as_posix()
    except ValueError:
        return target.as_posix()


def _moved(name: str, src_dir: Path, out_dir: Path) -> str | None:
    """The new value of a relative file name (``file://`` kept), None when it needs none."""
    scheme = "file://" if name.startswith("file://") else ""
    rest = name[len(scheme) :]
    if not rest or "://" in rest or Path(rest).is_absolute():
        return None
    return scheme + relative(src_dir / rest, out_dir)


def relocate_urdf(root: ET.Element, src_dir: Path, out_dir: Path) -> int:
    """Rewrite relative mesh/texture file names for a URDF written to ``out_dir``; count."""
    count = 0
    for el in root.iter():
        if el.tag in ("mesh", "texture") and (
            new := _moved(el.get("filename", ""), src_dir, out_dir)
        ):
            el.set("filename", new)
            count += 1
    return count


def relocate_mjcf(root: ET.Element, src_dir: Path, out_dir: Path) -> int:
    """Rewrite relative asset directories or file names for an MJCF (includes resolved)
    written to ``out_dir``; count."""
    compilers = list(root.iter("compiler"))
    count = 0
    for comp in compilers:
        for key in ("meshdir", "texturedir", "assetdir"):
            if new := _moved(comp.get(key, ""), src_dir, out_dir):
                comp.set(key, new)
                count += 1
    has = {k: any(c.get(k) for c in compilers) for k in ("meshdir", "texturedir", "assetdir")}
    strip = any(c.get("strippath") == "true" for c in compilers)
    for tag, (attrs, dir_key) in MJCF_FILES.items():
        in_dir = dir_key is not None and (has[dir_key] or has["assetdir"])
        for el in root.iter(tag):
            if in_dir or not any(el.get(a) for a in attrs):
                continue
            if strip and dir_key is not None:  # MuJoCo drops the path: point the folder instead
                target = compilers[0] if compilers else _new_compiler(root)
                target.set(dir_key, relative(src_dir, out_dir))
                has[dir_key] = True
                count += 1
                break
            for a in attrs:
                if new := _moved(el.get(a, ""), src_dir, out_dir):
                    el.set(a, new)
                    count += 1
    return count


def _new_compiler(root: ET.Element) -> ET.Element:
    comp = ET.Element("compiler")
    comp.tail = root.text if root.text and not root.text.strip() else None
    root.insert(0, comp)
    return comp


def resolve_includes(root: ET.Element, main: Path) -> list[Path]:
    """Replace every ``<include file>`` under ``root`` by the included file's content (in
    place, recursively); the files included. ModelError for a missing or circular include."""
    return _resolve(root, main, main.parent, [main.resolve()])


def _resolve(root: ET.Element, main: Path, here: Path, stack: list[Path]) -> list[Path]:
    files: list[Path] = []
    parents = {child: parent for parent in root.iter() for child in parent}
    for inc in [el for el in root.iter("include")]:
        name = inc.get("file")
        if not name:
            raise ModelError(f"{main}: an <include> has no file attribute")
        candidates = (
            [main.parent / name, here / name] if not Path(name).is_absolute() else [Path(name)]
        )
        path = next((p for p in candidates if p.is_file()), None)
        if path is None:
            raise ModelError(f"{main}: included file '{name}' not found (looked in {main.parent})")
        if path.resolve() in stack or len(stack) > _MAX_DEPTH:
            raise ModelError(f"{main}: '{name}' includes itself")
        sub = read_xml(path, "MJCF").root
        files += [path, *_resolve(sub, main, path.parent, [*stack, path.resolve()])]
        parent = parents[inc]
        at = list(parent).index(inc)
        children = list(sub)
        if children:
            children[-1].tail = inc.tail
        elif at > 0:
            parent[at - 1].tail = (parent[at - 1].tail or "") + (inc.tail or "")
        parent.remove(inc)
        for k, child in enumerate(children):
            parent.insert(at + k, child)
    return files


def model_files(path: str | Path) -> list[Path]:
    """Every file a model file reads: itself, the files it ``<include>``s (MJCF, nested) and
    the asset files (meshes, textures, …) its relative names point to — the inputs an export
    must never overwrite. Unreadable files are skipped (the model's reader reports them)."""
    main = Path(path)
    found: list[Path] = [main]
    try:
        root = ET.parse(main).getroot()
    except (ET.ParseError, OSError, UnicodeDecodeError, ValueError):
        return found
    if root.tag != "mujoco":  # URDF: mesh and texture file names
        for el in root.iter():
            name = el.get("filename", "") if el.tag in ("mesh", "texture") else ""
            rest = name[len("file://") :] if name.startswith("file://") else name
            if rest and "://" not in rest:
                found.append(Path(rest) if Path(rest).is_absolute() else main.parent / rest)
        return found
    try:
        found += resolve_includes(root, main)
    except ModelError:
        return found
    compilers = list(root.iter("compiler"))
    dirs: dict[str, str] = {}
    for k in ("meshdir", "texturedir", "assetdir"):
        dirs[k] = next((str(c.get(k)) for c in compilers if c.get(k)), "")
    for tag, (attrs, dir_key) in MJCF_FILES.items():
        folder = (dirs[dir_key] or dirs["assetdir"]) if dir_key else ""
        for el in root.iter(tag):
            for a in attrs:
                name = el.get(a)
                if name:
                    f = Path(folder) / name
                    found.append(f if f.is_absolute() else main.parent / f)
    return found


def missing_assets(path: str | Path) -> list[str]:
    """One warning line when asset files the model names (meshes, textures, …) do not exist:
    the export names them relative to its own folder as the source does, so neither loads in
    a simulator until they exist; [] when every one is there."""
    main = Path(path)
    files = model_files(main)[1:]
    gone = sorted({str(f) for f in files if not f.is_file()})
    if not gone:
        return []
    return [
        f"{len(gone)} asset file(s) that {main.name} names do not exist (e.g. {gone[0]}): the "
        "export points to them relative to its folder, and neither file loads in MuJoCo until "
        "they exist"
    ]
