"""RGB -> YUYV (YUV 4:2:2) as thesis section 4.6 defines it, vectorised.

Thesis code snippet 4.6.1 (float) and 4.6.2 (integer, "about 35 % faster"):

    y0 = (( 263 * r0 + 516 * g0 + 100 * b0) >> 10) + 16
    u  = ((-151 * r0 - 298 * g0 + 450 * b0) >> 10) + 128
    v  = (( 450 * r0 - 377 * g0 -  73 * b0) >> 10) + 128
    y1 = (( 263 * r1 + 516 * g1 + 100 * b1) >> 10) + 16

each clipped to 0..255. A pixel pair (r0 g0 b0, r1 g1 b1) becomes the four bytes
``y0 u y1 v``; chroma is taken from the pair's first pixel, as in the thesis.

Three implementations of the same formulas:

* ``yuv444_float``: snippet 4.6.1 with numpy float64 (values truncated like a C cast).
* ``yuv444_int_numpy``: snippet 4.6.2 with numpy int32, literally (the reference).
* ``yuv444_int``: snippet 4.6.2 through ``cv2.transform`` with the coefficients k/1024 and
  the offsets (16|128) - 1023/2048. Every product and sum is an exact binary fraction, so
  the rounding ``transform`` does to uint8 equals the arithmetic shift of the integer
  formula; it is checked against ``yuv444_int_numpy`` once per process (and exhaustively,
  over all 2**24 colours, in the unit tests) and falls back to numpy if it ever differs.

``Converter`` turns any sensor_msgs/Image (through ``simvid.imageconv``) into output frames
of a fixed size and pixel format (yuyv, uyvy or rgb24).
"""
import numpy as np

try:
    import cv2
except ImportError:  # pragma: no cover - python3-opencv is a declared dependency
    cv2 = None

from simvid import imageconv

__all__ = ['PIXEL_FORMATS', 'METHODS', 'yuv444_float', 'yuv444_int', 'yuv444_int_numpy',
           'yuv444_opencv', 'pack_422', 'rgb_to_frame', 'resize_rgb', 'Converter',
           'frame_size', 'yuyv_to_rgb']

PIXEL_FORMATS = ('yuyv', 'uyvy', 'rgb24')
METHODS = ('int', 'float', 'int_numpy', 'opencv')

INT_COEFFS = np.array([[263, 516, 100], [-151, -298, 450], [450, -377, -73]], np.int32)
FLOAT_COEFFS = np.array([[0.257, 0.504, 0.098], [-0.148, -0.291, 0.439],
                         [0.439, -0.368, -0.071]], np.float64)
OFFSETS = np.array([16, 128, 128], np.int32)

# cv2.transform matrix: exact binary fractions, see the module docstring
_CV_MATRIX = np.hstack([INT_COEFFS / 1024.0,
                        (OFFSETS - 1023.0 / 2048.0)[:, None]]).astype(np.float32)
_cv_exact = None  # None: not yet checked; True/False after the self-check


def _enc_matrix(order):
    """The transform matrix for input channels in ``order`` (e.g. 'bgra')."""
    cols = [_CV_MATRIX[:, 'rgb'.index(c)] if c in 'rgb' else np.zeros(3, np.float32)
            for c in order]
    return np.ascontiguousarray(np.column_stack(cols + [_CV_MATRIX[:, 3]]), np.float32)


_ENC_MATRIX = {'rgb8': _CV_MATRIX, 'bgr8': _enc_matrix('bgr'), 'rgba8': _enc_matrix('rgba'),
               'bgra8': _enc_matrix('bgra')}


def _as_rgb(rgb):
    rgb = np.asarray(rgb)
    if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError('expected an HxWx3 uint8 RGB array, got %s %s'
                         % (rgb.dtype, rgb.shape))
    return rgb


def yuv444_int_numpy(rgb):
    """Snippet 4.6.2 for every pixel: HxWx3 uint8 (Y, U, V), plain numpy int32."""
    rgb = _as_rgb(rgb).astype(np.int32)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    out = np.empty(rgb.shape, np.uint8)
    for i in range(3):
        k = INT_COEFFS[i]
        val = ((k[0] * r + k[1] * g + k[2] * b) >> 10) + OFFSETS[i]
        out[..., i] = np.clip(val, 0, 255)
    return out


def yuv444_float(rgb):
    """Snippet 4.6.1 for every pixel (float, truncated to an integer like a C cast)."""
    rgb = _as_rgb(rgb).astype(np.float64)
    val = rgb @ FLOAT_COEFFS.T + OFFSETS
    return np.clip(val, 0, 255).astype(np.uint8)


def _check_cv_exact():
    global _cv_exact
    if _cv_exact is None:
        if cv2 is None:
            _cv_exact = False
        else:
            rng = np.random.RandomState(4611)
            probe = rng.randint(0, 256, (64, 1024, 3)).astype(np.uint8)
            grid = np.arange(0, 256, 15, dtype=np.uint8)
            cube = np.stack(np.meshgrid(grid, grid, grid, indexing='ij'), -1)
            probe[:1, :cube.size // 3] = cube.reshape(1, -1, 3)[:, :1024]
            probe[1, :6] = [[0, 0, 0], [255, 255, 255], [255, 0, 0], [0, 255, 0],
                            [0, 0, 255], [0, 255, 255]]
            _cv_exact = bool(np.array_equal(cv2.transform(probe, _CV_MATRIX),
                                            yuv444_int_numpy(probe)))
    return _cv_exact


def yuv444_int(rgb):
    """Snippet 4.6.2 for every pixel, the fast path (see module docstring)."""
    rgb = _as_rgb(rgb)
    if _check_cv_exact():
        return cv2.transform(rgb, _CV_MATRIX)
    return yuv444_int_numpy(rgb)


def yuv444_opencv(rgb):
    """OpenCV's own RGB -> YUV (BT.601 full range, other coefficients): benchmark only."""
    return cv2.cvtColor(_as_rgb(rgb), cv2.COLOR_RGB2YUV)


_YUV444 = {'int': yuv444_int, 'float': yuv444_float, 'int_numpy': yuv444_int_numpy,
           'opencv': yuv444_opencv}


def pack_422(yuv, order='yuyv', out=None):
    """HxWx3 (Y, U, V per pixel) -> HxWx2 packed 4:2:2 bytes, chroma of the even pixel.

    ``order`` 'yuyv' gives y0 u y1 v, 'uyvy' gives u y0 v y1. The width must be even.
    """
    h, w = yuv.shape[:2]
    if w % 2:
        raise ValueError('4:2:2 needs an even width, got %d' % w)
    if out is None:
        out = np.empty((h, w, 2), np.uint8)
    yi, ci = (0, 1) if order == 'yuyv' else (1, 0)
    out[:, :, yi] = yuv[:, :, 0]
    out[:, 0::2, ci] = yuv[:, 0::2, 1]
    out[:, 1::2, ci] = yuv[:, 0::2, 2]
    return out


def frame_size(width, height, pixel_format):
    return width * height * (3 if pixel_format == 'rgb24' else 2)


def rgb_to_frame(rgb, pixel_format='yuyv', method='int', out=None):
    """HxWx3 RGB -> packed frame array (HxWx2 for yuyv/uyvy, HxWx3 for rgb24)."""
    if pixel_format == 'rgb24':
        return np.ascontiguousarray(_as_rgb(rgb))
    if pixel_format not in ('yuyv', 'uyvy'):
        raise ValueError('unsupported pixel_format %r (use one of %s)'
                         % (pixel_format, ', '.join(PIXEL_FORMATS)))
    if method not in _YUV444:
        raise ValueError('unsupported conversion method %r (use one of %s)'
                         % (method, ', '.join(METHODS)))
    return pack_422(_YUV444[method](rgb), pixel_format, out)


def resize_rgb(rgb, width, height):
    """Scale to width x height (bilinear, area when shrinking); no copy if it fits."""
    h, w = rgb.shape[:2]
    if (w, h) == (width, height):
        return rgb
    interp = cv2.INTER_AREA if (w > width and h > height) else cv2.INTER_LINEAR
    return cv2.resize(np.ascontiguousarray(rgb), (width, height), interpolation=interp)


def yuyv_to_rgb(frame, width, height):
    """Decode a YUYV frame (bytes) back to RGB with OpenCV, for checks and viewers."""
    arr = np.frombuffer(frame, np.uint8, count=width * height * 2).reshape(height, width, 2)
    return cv2.cvtColor(arr, cv2.COLOR_YUV2RGB_YUYV)


class Converter(object):
    """sensor_msgs/Image -> output frame bytes of a fixed size and pixel format.

    Raises ``imageconv.UnsupportedEncoding`` (a ValueError) for images it cannot read.
    """

    def __init__(self, width=640, height=480, pixel_format='yuyv', method='int'):
        width, height = int(width), int(height)
        if width <= 0 or height <= 0:
            raise ValueError('output size must be positive, got %dx%d' % (width, height))
        if pixel_format not in PIXEL_FORMATS:
            raise ValueError('unsupported pixel_format %r (use one of %s)'
                             % (pixel_format, ', '.join(PIXEL_FORMATS)))
        if pixel_format in ('yuyv', 'uyvy') and width % 2:
            raise ValueError('%s needs an even width, got %d (try %d)'
                             % (pixel_format, width, width + 1))
        if method not in METHODS:
            raise ValueError('unsupported conversion method %r' % method)
        self.width, self.height = width, height
        self.pixel_format, self.method = pixel_format, method
        self.frame_size = frame_size(width, height, pixel_format)
        ch = 3 if pixel_format == 'rgb24' else 2
        self._out = np.empty((height, width, ch), np.uint8)

    def _fast_yuv444(self, msg):
        """bgr8 / rgba8 / bgra8 straight from the message's buffer: the channel order is
        folded into the cv2.transform matrix (a zero column for alpha), so there is no
        reordering copy. Same exact arithmetic as ``yuv444_int``. None if not applicable."""
        if self.method != 'int' or self.pixel_format == 'rgb24' or not _check_cv_exact():
            return None
        arr, enc = imageconv.image_to_array(msg)
        m = _ENC_MATRIX.get(enc)
        if m is None:
            return None
        arr = resize_rgb(arr, self.width, self.height)
        return cv2.transform(np.ascontiguousarray(arr), m)

    def rgb_to_bytes(self, rgb):
        rgb = resize_rgb(rgb, self.width, self.height)
        if self.pixel_format == 'rgb24':
            self._out[...] = rgb
        else:
            rgb_to_frame(rgb, self.pixel_format, self.method, out=self._out)
        return self._out.tobytes()

    def convert(self, msg):
        """sensor_msgs/Image -> bytes (one frame)."""
        yuv = self._fast_yuv444(msg)
        if yuv is not None:
            return pack_422(yuv, self.pixel_format, self._out).tobytes()
        return self.rgb_to_bytes(imageconv.image_to_rgb(msg))
