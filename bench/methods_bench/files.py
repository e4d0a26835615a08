"""files.py - the .opm container (docs/formats.md) through the add-on's reader
(blender_addon/opaline/opm.py, the one Python reader, imported as a plain module: see
__init__.py), and its sections as numpy arrays."""

import opm


def opm_sections(path):
    """{tag: (offset, size)} and the META dict of a material file; checks magic, version and
    size (opm.OpmError, a ValueError, otherwise)."""
    secs = opm.sections(path)
    return secs, opm.read_meta(path, secs)


def opm_array(np, path, secs, tag, dtype, cols=None):
    """Section tag of path as a read-only numpy memmap (rows x cols when cols is given)."""
    off, size = secs[tag]
    n = size // np.dtype(dtype).itemsize
    a = np.memmap(path, dtype=dtype, mode="r", offset=off, shape=(n,))
    return a.reshape(-1, cols) if cols else a
