"""Read an X window dump (``xwd -root``) into an RGB numpy array: the screenshots of the rviz
test, without ImageMagick."""
import struct

import numpy as np

__all__ = ['read_xwd']


def read_xwd(data):
    """(height, width, 3) uint8 RGB of a 24/32-bit TrueColor ZPixmap dump (bytes)."""
    fields = struct.unpack('>25I', data[:100])
    (header_size, _version, fmt, depth, width, height, _xoff, byte_order, _unit, _bit_order,
     _pad, bpp, bytes_per_line, _vclass, red_mask, green_mask, blue_mask, _bits_rgb,
     _cmap_entries, ncolors) = fields[:20]
    if fmt != 2 or bpp not in (24, 32) or depth not in (24, 32):
        raise ValueError('only 24/32-bit ZPixmap dumps are read, got format %d, depth %d, '
                         '%d bits per pixel' % (fmt, depth, bpp))
    start = header_size + 12 * ncolors
    raw = np.frombuffer(data, dtype=np.uint8, count=height * bytes_per_line, offset=start)
    nb = bpp // 8
    px = raw.reshape(height, bytes_per_line)[:, :width * nb].reshape(height, width, nb)
    px = px.astype(np.uint32)
    order = range(nb) if byte_order == 0 else range(nb - 1, -1, -1)   # LSBFirst: byte 0 low
    words = np.zeros((height, width), np.uint32)
    for k, b in enumerate(order):
        words |= px[:, :, b] << (8 * k)
    out = np.empty((height, width, 3), np.uint8)
    for i, mask in enumerate((red_mask, green_mask, blue_mask)):
        shift = (mask & -mask).bit_length() - 1
        out[:, :, i] = (words & mask) >> shift
    return out
