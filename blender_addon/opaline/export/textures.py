"""Image Texture nodes -> Mitsuba `bitmap` textures, their images written beside the XML.

`texture_for(socket, param, writer, warn, label)` follows a linked colour input (through
reroutes) to an Image Texture node and returns a <texture type="bitmap" name=PARAM> element,
or None (after a warning) when the link leads elsewhere. The node's settings map as follows:
- extension: REPEAT -> wrapMode repeat, EXTEND -> clamp, CLIP -> zero (Cycles gives black
  outside the image), MIRROR -> mirror;
- interpolation: Closest -> filterType nearest; Linear and Smart -> bilinear (no filterType
  written: Mitsuba's default, which opaline renders bilinear); Cubic -> bilinear, warned;
- colour space: sRGB -> gamma -1; Non-Color, Linear, Raw (and other linear spaces) -> gamma 1;
  any other space -> the file's default, warned;
- a Mapping node (Point type, no rotation) on the UV coordinates -> uscale/vscale and
  uoffset/voffset (accounting for the exported v = 1 - v); other vector inputs: warned, plain UVs.

Images (TextureWriter) go to `textures/NAME-<hash>.<ext>` beside the XML, content-addressed like
the meshes (an unchanged image is not rewritten; one image used by several materials is written
once per export): 8-bit PNG and OpenEXR files, on disk or packed, are copied byte for byte;
anything else opaline cannot read (JPEG, TGA, 16-bit PNG, generated or painted images) is
saved from Blender's pixels, byte images as 8-bit PNG (values as stored, so the colour space
still applies), float images as PFM (Blender holds them linear: gamma 1).
Pure Python (zlib, struct, array): Debian's Blender has no NumPy.
"""

import array
import hashlib
import os
import struct
import sys
import zlib

from .meshes import safe_name
from .xml_writer import Element, write_bytes

TEXTURE_FOLDER = "textures"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
EXR_MAGIC = b"\x76\x2f\x31\x01"

WRAP = {"REPEAT": "repeat", "EXTEND": "clamp", "CLIP": "zero", "MIRROR": "mirror"}
LINEAR_SPACES = {"Non-Color", "Linear", "Linear Rec.709", "Raw", "Linear ACES", "Linear ACEScg",
                 "Linear CIE-XYZ E", "Linear CIE-XYZ D65", "XYZ"}


def linked_source(socket):
    """(node, output socket) feeding `socket`, through reroutes; (None, None) if unlinked."""
    if socket is None or not socket.is_linked:
        return None, None
    link = socket.links[0]
    node, out = link.from_node, link.from_socket
    while node.bl_idname == "NodeReroute":
        if not node.inputs[0].is_linked:
            return None, None
        link = node.inputs[0].links[0]
        node, out = link.from_node, link.from_socket
    return node, out


def _png_8bit(data):
    """Whether data is a PNG of bit depth 8 or less (what opaline decodes as 8-bit sRGB)."""
    return data[:8] == PNG_MAGIC and len(data) > 24 and data[24] <= 8


def png_bytes(width, height, channels, values):
    """An 8-bit RGB PNG of `values` (floats in [0, 1], `channels` per pixel, rows bottom to top
    as Blender stores them)."""
    rows = []
    for y in range(height - 1, -1, -1):
        base = y * width * channels
        row = bytearray(1 + 3 * width)  # filter byte 0, then RGB
        for x in range(width):
            p = base + x * channels
            for c in range(3):
                v = values[p + (c if channels >= 3 else 0)]
                row[1 + 3 * x + c] = 0 if not v > 0.0 else 255 if v >= 1.0 else int(v * 255 + 0.5)
        rows.append(bytes(row))

    def chunk(kind, body):
        return (struct.pack(">I", len(body)) + kind + body +
                struct.pack(">I", zlib.crc32(kind + body) & 0xffffffff))
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (PNG_MAGIC + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"".join(rows), 6)) +
            chunk(b"IEND", b""))


def pfm_bytes(width, height, channels, values):
    """A little-endian RGB PFM of float `values` (rows bottom to top, as PFM stores them)."""
    n = width * height
    out = array.array('f', bytes(12 * n))
    src = array.array('f', values)
    for c in range(3):
        out[c::3] = src[(c if channels >= 3 else 0)::channels]
    if sys.byteorder != "little":
        out.byteswap()
    return ("PF\n%d %d\n-1.0\n" % (width, height)).encode("ascii") + out.tobytes()


class TextureWriter:
    """Writes each image once per export into `xml_dir/textures/`; counts what it did."""

    def __init__(self, xml_dir):
        self.dir = os.path.join(xml_dir, TEXTURE_FOLDER)
        self.files = {}  # image name -> (relative path, is float data) or None
        self.written = 0
        self.reused = 0

    def _source_bytes(self, image):
        """The bytes of the image's file (packed or on disk), or None."""
        if image.packed_file is not None:
            try:
                return bytes(image.packed_file.data)
            except (TypeError, ValueError):
                return None
        if image.source != 'FILE':
            return None
        import bpy
        path = bpy.path.abspath(image.filepath_raw or image.filepath, library=image.library)
        if not path or not os.path.isfile(path):
            return None
        with open(path, "rb") as fh:
            return fh.read()

    def image_file(self, image, warn, label):
        """(path relative to the XML, saved_from_float_pixels) of `image`, or None."""
        key = image.name
        if key in self.files:
            return self.files[key]
        res = None
        data = self._source_bytes(image)
        float_pixels = False
        if data is not None and (_png_8bit(data) or data[:4] == EXR_MAGIC):
            ext = "png" if data[:8] == PNG_MAGIC else "exr"
        else:
            w, h = image.size
            if image.source not in ('FILE', 'GENERATED') or w == 0 or h == 0:
                warn("%s: image '%s' (%s) has no pixels opaline can read; its texture is not "
                     "exported" % (label, image.name, image.source.lower()))
                self.files[key] = None
                return None
            ch = image.channels
            px = array.array('f', bytes(4 * w * h * ch))
            image.pixels.foreach_get(px)
            if image.is_float:
                data, ext, float_pixels = pfm_bytes(w, h, ch, px), "pfm", True
            else:
                data, ext = png_bytes(w, h, ch, px), "png"
        digest = hashlib.sha1(data).hexdigest()[:16]
        fname = "%s-%s.%s" % (safe_name(os.path.splitext(image.name)[0]), digest, ext)
        path = os.path.join(self.dir, fname)
        if os.path.isfile(path) and os.path.getsize(path) == len(data):
            self.reused += 1
        else:
            write_bytes(path, (data,))
            self.written += 1
        res = (TEXTURE_FOLDER + "/" + fname, float_pixels)
        self.files[key] = res
        return res


def _mapping(node, tex, warn, label):
    """Adds uscale/vscale/uoffset/voffset for the Image Texture node's Vector input."""
    src, out = linked_source(node.inputs.get("Vector"))
    if src is None:
        return
    if src.bl_idname == "ShaderNodeMapping":
        vt = getattr(src, "vector_type", "POINT")
        rot = src.inputs.get("Rotation")
        loc = src.inputs.get("Location")
        scl = src.inputs.get("Scale")
        linked = any(s is not None and s.is_linked for s in (rot, loc, scl))
        r = rot.default_value if rot is not None else (0, 0, 0)
        if vt == 'POINT' and not linked and max(abs(r[0]), abs(r[1]), abs(r[2])) < 1e-6:
            sx, sy = float(scl.default_value[0]), float(scl.default_value[1])
            lx, ly = float(loc.default_value[0]), float(loc.default_value[1])
            # Blender looks up (u, v) * s + l with v from the bottom row; the export writes
            # v' = 1 - v and opaline reads rows from the top: v'_lookup = v' sy + (1 - sy - ly)
            if abs(sx - 1.0) > 1e-9:
                tex.float("uscale", sx)
            if abs(sy - 1.0) > 1e-9:
                tex.float("vscale", sy)
            if abs(lx) > 1e-9:
                tex.float("uoffset", lx)
            if abs(1.0 - sy - ly) > 1e-9:
                tex.float("voffset", 1.0 - sy - ly)
            src, out = linked_source(src.inputs.get("Vector"))
            if src is None:
                return
        else:
            warn("%s: the Mapping node before image '%s' is not a plain scale and offset "
                 "(rotation, a linked value or a non-Point type); it is ignored"
                 % (label, node.image.name))
            return
    if src.bl_idname == "ShaderNodeUVMap" or (src.bl_idname == "ShaderNodeTexCoord" and
                                              out is not None and out.name == "UV"):
        return
    warn("%s: image '%s' uses %s coordinates; opaline exports the UV map only, so the texture "
         "follows the UVs" % (label, node.image.name,
                              out.name if out is not None else src.bl_idname))


def texture_for(socket, param, writer, warn, label):
    """A <texture type="bitmap" name=param> for a colour socket linked to an Image Texture
    node's Color output, or None (with a warning) when it is linked to anything else or the
    image cannot be exported."""
    node, out = linked_source(socket)
    if node is None:
        return None
    if node.bl_idname != "ShaderNodeTexImage" or (out is not None and out.name != "Color"):
        warn("%s: input '%s' is linked to %s; only an Image Texture's Color is exported, the "
             "default value is used" % (label, socket.name, node.bl_idname
                                        if node.bl_idname != "ShaderNodeTexImage"
                                        else "an Image Texture's " + out.name))
        return None
    image = node.image
    if image is None:
        warn("%s: the Image Texture on '%s' has no image; the default value is used"
             % (label, socket.name))
        return None
    if image.source == 'TILED':
        warn("%s: image '%s' is a UDIM tile set, which is not exported; the default value is "
             "used" % (label, image.name))
        return None
    got = writer.image_file(image, warn, label)
    if got is None:
        return None
    rel, float_pixels = got
    tex = Element("texture", {"type": "bitmap", "name": param},
                  comment="image %s" % image.name)
    tex.string("filename", rel)
    ext = getattr(node, "extension", "REPEAT")
    tex.string("wrapMode", WRAP.get(ext, "repeat"))
    if ext not in WRAP:
        warn("%s: image '%s': extension %s is exported as repeat" % (label, image.name, ext))
    interp = getattr(node, "interpolation", "Linear")
    if interp == "Closest":
        tex.string("filterType", "nearest")
    elif interp == "Cubic":
        warn("%s: image '%s': cubic interpolation is rendered bilinear" % (label, image.name))
    space = image.colorspace_settings.name
    if float_pixels:
        tex.float("gamma", 1.0)  # Blender's float buffers are linear already
    elif space == "sRGB":
        tex.float("gamma", -1.0)
    elif space in LINEAR_SPACES:
        tex.float("gamma", 1.0)
    else:
        warn("%s: image '%s': colour space '%s' is not mapped; the file's default is used "
             "(sRGB for PNG, linear for EXR)" % (label, image.name, space))
    _mapping(node, tex, warn, label)
    return tex
