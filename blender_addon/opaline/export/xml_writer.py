"""A small writer for Mitsuba-0.5-style scene XML.

Elements are built as a tree of `Element` objects and serialized with two-space indentation.
Numbers are written with `fmt()`, which keeps nine significant digits (enough for float32
round-trips) and never writes exponents for ordinary scene values; attribute values are
escaped, for XML and for opaline's `$name` parameters (`attr_value`). The writer knows nothing
of Blender, so it can be tested on its own.
"""

from xml.sax.saxutils import quoteattr

SCENE_VERSION = "0.5.0"


def fmt(x):
    """Formats one number for an attribute: integers stay integral, floats get %.9g."""
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, int):
        return str(x)
    v = float(x)
    if v == 0.0:
        return "0"
    s = "%.9g" % v
    return s


def attr_value(v):
    """v as an attribute value that opaline-render reads back as v: a `$` there starts a
    $parameter, so a literal one is written `$$` (docs/scene-format.md); quoted for XML."""
    return quoteattr(str(v).replace("$", "$$"))


def fmt_list(values, sep=", "):
    return sep.join(fmt(v) for v in values)


class Element:
    """One XML element: a tag, ordered attributes, child elements and an optional comment."""

    __slots__ = ("tag", "attrs", "children", "comment")

    def __init__(self, tag, attrs=None, children=None, comment=None):
        self.tag = tag
        self.attrs = list((attrs or {}).items())
        self.children = list(children or [])
        self.comment = comment

    def add(self, child):
        self.children.append(child)
        return child

    # Typed property helpers (Mitsuba grammar).
    def float(self, name, value):
        return self.add(Element("float", {"name": name, "value": fmt(float(value))}))

    def integer(self, name, value):
        return self.add(Element("integer", {"name": name, "value": str(int(value))}))

    def boolean(self, name, value):
        return self.add(Element("boolean", {"name": name, "value": "true" if value else "false"}))

    def string(self, name, value):
        return self.add(Element("string", {"name": name, "value": str(value)}))

    def rgb(self, name, rgb):
        return self.add(Element("rgb", {"name": name, "value": fmt_list(rgb[:3])}))

    def point(self, name, p):
        return self.add(Element("point", {"name": name, "x": fmt(p[0]), "y": fmt(p[1]),
                                          "z": fmt(p[2])}))

    def vector(self, name, v):
        return self.add(Element("vector", {"name": name, "x": fmt(v[0]), "y": fmt(v[1]),
                                           "z": fmt(v[2])}))

    def write(self, out, depth=0):
        pad = "    " * depth
        if self.comment:
            out.append("%s<!-- %s -->" % (pad, self.comment.replace("--", "- -")))
        attrs = "".join(" %s=%s" % (k, attr_value(v)) for k, v in self.attrs)
        if not self.children:
            out.append("%s<%s%s/>" % (pad, self.tag, attrs))
            return
        out.append("%s<%s%s>" % (pad, self.tag, attrs))
        for c in self.children:
            c.write(out, depth + 1)
        out.append("%s</%s>" % (pad, self.tag))


def transform_matrix(name, rows):
    """<transform name=NAME><matrix value="16 numbers, row-major"/></transform>."""
    flat = [rows[r][c] for r in range(4) for c in range(4)]
    t = Element("transform", {"name": name})
    t.add(Element("matrix", {"value": fmt_list(flat, " ")}))
    return t


def transform_lookat(name, origin, target, up):
    t = Element("transform", {"name": name})
    t.add(Element("lookat", {"origin": fmt_list(origin), "target": fmt_list(target),
                             "up": fmt_list(up)}))
    return t


def scene_element():
    return Element("scene", {"version": SCENE_VERSION})


def serialize(root, header_comment=None):
    """The whole document as a string (with XML declaration and a trailing newline)."""
    out = ['<?xml version="1.0" encoding="utf-8"?>']
    if header_comment:
        out.append("<!-- %s -->" % header_comment.replace("--", "- -"))
    root.write(out)
    return "\n".join(out) + "\n"


def _umask_mode():
    import os
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def write_file(path, text):
    """Writes text (UTF-8) to path through a temporary file renamed into place (never
    half-written)."""
    write_bytes(path, [text.encode("utf-8")])


def write_bytes(path, chunks):
    """Writes the bytes-like chunks (an iterable) to path through a temporary file renamed into
    place (never half-written)."""
    import os
    import tempfile
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".opaline-", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            for c in chunks:
                f.write(c)
        os.chmod(tmp, _umask_mode())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
