"""Namespace prefixes a URDF uses without declaring them (``drake:acceleration``), declared so XML readers accept them.

urdfdom (TinyXML) reads ``<limit drake:acceleration="2.5">`` as an attribute literally named
``drake:acceleration`` and ignores it; a namespace-aware reader (expat, lxml) refuses the whole
file ("unbound prefix"). airo-models' UR arms and Robotiq gripper are written so, for Drake.
:func:`declare_unbound_prefixes` adds ``xmlns:drake="urn:robodyn:undeclared:drake"`` to the
root element, so that every reader sees the same elements and attributes urdfdom sees (under a
namespace no URDF element has: they stay extensions, ignored as urdfdom ignores them).
"""

from __future__ import annotations

import re
import xml.parsers.expat

UNDECLARED = "urn:robodyn:undeclared:"  # the namespace given to a prefix the file did not declare

# A qualified name's prefix, in a start or end tag or before an attribute's '='.
_USED = re.compile(rb"(?:</?|\s)([A-Za-z_][\w.-]*):[A-Za-z_][\w.-]*(?=[\s/>=])")
_DECLARED = re.compile(rb"xmlns:([A-Za-z_][\w.-]*)\s*=")


def declare_unbound_prefixes(data: bytes) -> bytes:
    """``data`` with a declaration on its root element for each prefix it uses but never declares.

    ``data`` is returned unchanged when it uses no undeclared prefix, or when it is not XML that
    expat can read without namespaces (the namespace-aware reader then reports what is wrong).
    """
    missing = sorted(set(_USED.findall(data)) - set(_DECLARED.findall(data)) - {b"xml", b"xmlns"})
    if not missing:
        return data
    parser = xml.parsers.expat.ParserCreate()  # without namespaces: "drake:member" is a plain name
    found: list[tuple[int, str]] = []

    def first_start(name: str, attributes: dict[str, str]) -> None:
        if not found:
            found.append((parser.CurrentByteIndex, name))

    parser.StartElementHandler = first_start
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError:
        if not found:
            return data
    if not found:
        return data
    start, name = found[0]
    at = start + 1 + len(name.encode("utf-8"))  # just after "<robot"
    declarations = b"".join(b' xmlns:%s="%s%s"' % (p, UNDECLARED.encode(), p) for p in missing)
    return data[:at] + declarations + data[at:]
