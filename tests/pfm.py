"""The PFM reader of the Python tests and benchmarks (standard library only, so that it runs
inside Blender too): the add-on tests (tests/addon), the end-to-end scripts' Python parts and
bench/. Import it with tests/ on sys.path."""

import struct


class Image:
    """A PFM image: width, height, channels (3 for PF, 1 for Pf) and samples, a flat tuple of
    floats, rows bottom-up (PFM's order) and channels interleaved."""

    def __init__(self, width, height, channels, samples):
        self.width, self.height, self.channels, self.samples = width, height, channels, samples

    def pixel(self, x, y):
        """The channels of the pixel in column x, row y counted from the top."""
        i = ((self.height - 1 - y) * self.width + x) * self.channels
        return self.samples[i:i + self.channels]

    def rows(self):
        """The rows bottom-up, each a tuple of its samples."""
        n = self.width * self.channels
        return [self.samples[n * y:n * (y + 1)] for y in range(self.height)]


def read(path):
    """The Image in the PFM file at path; ValueError when it is not one."""
    with open(path, "rb") as f:
        data = f.read()
    fields, pos = [], 0
    while len(fields) < 4:  # the header: PF|Pf, width, height, scale, separated by whitespace
        while data[pos:pos + 1].isspace():
            pos += 1
        end = pos
        while end < len(data) and not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    pos += 1
    if fields[0] not in (b"PF", b"Pf"):
        raise ValueError("%s: not a PFM image (%r)" % (path, fields[0]))
    w, h, scale = int(fields[1]), int(fields[2]), float(fields[3])
    ch = 3 if fields[0] == b"PF" else 1
    n = w * h * ch
    if len(data) - pos < 4 * n:
        raise ValueError("%s: %d bytes of samples, %d expected" % (path, len(data) - pos, 4 * n))
    samples = struct.unpack_from(("<" if scale < 0 else ">") + "%df" % n, data, pos)
    return Image(w, h, ch, samples)
