"""RGB -> YUYV of thesis section 4.6: the integer arithmetic of code snippet 4.6.2 against
the float formula of snippet 4.6.1 and an independent per-pixel reference, packing,
resizing, every encoding and odd widths."""
import numpy as np
import pytest

from simvid import yuv
from simvid.imageconv import UnsupportedEncoding, array_to_image


def ref_pixel_int(r, g, b):
    """Snippet 4.6.2 for one pixel, plain Python integers."""
    clip = lambda v: max(0, min(255, v))  # noqa: E731
    y = clip(((263 * r + 516 * g + 100 * b) >> 10) + 16)
    u = clip(((-151 * r - 298 * g + 450 * b) >> 10) + 128)
    v = clip(((450 * r - 377 * g - 73 * b) >> 10) + 128)
    return y, u, v


def ref_pixel_float(r, g, b):
    """Snippet 4.6.1 for one pixel, float, truncated like a C cast after clipping."""
    clip = lambda v: int(max(0.0, min(255.0, v)))  # noqa: E731
    return (clip(0.257 * r + 0.504 * g + 0.098 * b + 16),
            clip(-0.148 * r - 0.291 * g + 0.439 * b + 128),
            clip(0.439 * r - 0.368 * g - 0.071 * b + 128))


def ref_yuyv(rgb):
    """Per-pixel-pair reference of the thesis scheme: y0 u y1 v, chroma of pixel 0."""
    h, w, _ = rgb.shape
    out = bytearray()
    for row in rgb.tolist():
        for x in range(0, w, 2):
            y0, u, v = ref_pixel_int(*row[x])
            y1 = ref_pixel_int(*row[x + 1])[0]
            out += bytes((y0, u, y1, v))
    return bytes(out)


def all_colours():
    c = np.arange(1 << 24, dtype=np.uint32)
    return np.stack([(c >> 16) & 255, (c >> 8) & 255, c & 255], -1).astype(np.uint8) \
        .reshape(4096, 4096, 3)


def test_integer_path_matches_reference_pixels():
    rng = np.random.RandomState(1)
    rgb = rng.randint(0, 256, (3, 500, 3)).astype(np.uint8)
    rgb[0, :8] = [[0, 0, 0], [255, 255, 255], [255, 0, 0], [0, 255, 0], [0, 0, 255],
                  [255, 255, 0], [0, 255, 255], [255, 0, 255]]
    got = yuv.yuv444_int(rgb)
    want = np.array([[ref_pixel_int(*p) for p in row] for row in rgb.tolist()], np.uint8)
    assert np.array_equal(got, want)
    assert np.array_equal(yuv.yuv444_int_numpy(rgb), want)


def test_integer_path_exact_for_every_colour():
    """The fast path (cv2.transform with exact binary-fraction coefficients) equals the
    literal integer formula for all 2**24 colours."""
    rgb = all_colours()
    assert np.array_equal(yuv.yuv444_int(rgb), yuv.yuv444_int_numpy(rgb))


def test_integer_within_one_level_of_float_for_every_colour():
    rgb = all_colours()[::4]  # 4M colours, every 4th row: still every value of r, g, b
    diff = np.abs(yuv.yuv444_int(rgb).astype(np.int16) - yuv.yuv444_float(rgb).astype(np.int16))
    assert diff.max() <= 1
    assert (diff > 0).mean() < 0.5   # mostly equal, not a constant offset


def test_float_path_matches_reference_pixels():
    rng = np.random.RandomState(2)
    rgb = rng.randint(0, 256, (2, 300, 3)).astype(np.uint8)
    want = np.array([[ref_pixel_float(*p) for p in row] for row in rgb.tolist()], np.uint8)
    assert np.array_equal(yuv.yuv444_float(rgb), want)


def test_known_colours():
    # BT.601 studio swing: black 16/128/128, white 235/128/128 (within the 10-bit rounding)
    black = yuv.yuv444_int(np.zeros((1, 1, 3), np.uint8))[0, 0].tolist()
    white = yuv.yuv444_int(np.full((1, 1, 3), 255, np.uint8))[0, 0].tolist()
    assert black == [16, 128, 128]
    assert white[0] in (234, 235) and all(abs(c - 128) <= 1 for c in white[1:])


def test_yuyv_packing_matches_pairwise_reference():
    rng = np.random.RandomState(3)
    rgb = rng.randint(0, 256, (5, 12, 3)).astype(np.uint8)
    assert yuv.rgb_to_frame(rgb, 'yuyv').tobytes() == ref_yuyv(rgb)


def test_uyvy_and_rgb24():
    rng = np.random.RandomState(4)
    rgb = rng.randint(0, 256, (4, 8, 3)).astype(np.uint8)
    yuyv = yuv.rgb_to_frame(rgb, 'yuyv').reshape(4, 4, 4)
    uyvy = yuv.rgb_to_frame(rgb, 'uyvy').reshape(4, 4, 4)
    assert np.array_equal(uyvy, yuyv[:, :, [1, 0, 3, 2]])
    assert yuv.rgb_to_frame(rgb, 'rgb24').tobytes() == rgb.tobytes()


def test_opencv_decodes_our_yuyv_close_to_the_source():
    import cv2
    rng = np.random.RandomState(5)
    rgb = cv2.GaussianBlur(rng.randint(0, 256, (48, 64, 3)).astype(np.uint8), (9, 9), 3)
    frame = yuv.rgb_to_frame(rgb, 'yuyv')
    back = cv2.cvtColor(frame, cv2.COLOR_YUV2RGB_YUYV).astype(int)
    # 4:2:2 from the even pixel loses some chroma; smooth pictures come back close
    assert np.abs(back - rgb.astype(int)).mean() < 6


def test_odd_width_is_a_clear_error_not_a_crash():
    with pytest.raises(ValueError, match='even width'):
        yuv.Converter(641, 480, 'yuyv')
    with pytest.raises(ValueError, match='even width'):
        yuv.pack_422(np.zeros((2, 3, 3), np.uint8))
    yuv.Converter(641, 480, 'rgb24')  # no pairing: fine


def test_odd_input_sizes_are_resized():
    conv = yuv.Converter(64, 48)
    for w, h in [(63, 47), (1, 1), (641, 481), (64, 48)]:
        img = array_to_image(np.full((h, w, 3), 200, np.uint8), 'rgb8')
        out = conv.convert(img)
        assert len(out) == 64 * 48 * 2
        y = np.frombuffer(out, np.uint8)[0::2]
        assert np.all(y == ref_pixel_int(200, 200, 200)[0])


def test_resize_content():
    rgb = np.zeros((20, 40, 3), np.uint8)
    rgb[:, 20:] = 255  # left black, right white
    small = yuv.resize_rgb(rgb, 10, 5)
    assert small.shape == (5, 10, 3)
    assert small[:, :4].max() == 0 and small[:, 6:].min() == 255
    assert yuv.resize_rgb(rgb, 40, 20) is rgb


ENCODINGS = {
    'rgb8': lambda rgb: rgb,
    'bgr8': lambda rgb: rgb[:, :, ::-1],
    'rgba8': lambda rgb: np.dstack([rgb, np.full(rgb.shape[:2], 7, np.uint8)]),
    'bgra8': lambda rgb: np.dstack([rgb[:, :, ::-1], np.full(rgb.shape[:2], 7, np.uint8)]),
}


@pytest.mark.parametrize('enc', sorted(ENCODINGS))
def test_every_colour_encoding_gives_the_same_frame(enc):
    rng = np.random.RandomState(6)
    rgb = rng.randint(0, 256, (6, 10, 3)).astype(np.uint8)
    conv = yuv.Converter(10, 6)
    want = yuv.rgb_to_frame(rgb).tobytes()
    assert conv.convert(array_to_image(ENCODINGS[enc](rgb), enc)) == want


def test_mono_and_16bit_and_yuv422_encodings():
    conv = yuv.Converter(8, 4)
    grey = np.arange(32, dtype=np.uint8).reshape(4, 8) * 8
    out = np.frombuffer(conv.convert(array_to_image(grey, 'mono8')), np.uint8)
    assert np.array_equal(out[0::2], [ref_pixel_int(g, g, g)[0] for g in grey.ravel()])
    # 16 bit grey through cv_bridge (65535 -> white)
    from sensor_msgs.msg import Image
    m = Image(height=4, width=8, encoding='mono16', is_bigendian=0, step=16,
              data=np.full((4, 8), 65535, np.uint16).tobytes())
    y = np.frombuffer(conv.convert(m), np.uint8)[0::2]
    assert np.all(y == ref_pixel_int(255, 255, 255)[0])


def test_unsupported_encoding_raises_clear_error():
    from sensor_msgs.msg import Image
    conv = yuv.Converter(8, 4)
    m = Image(height=4, width=8, encoding='no_such_encoding', step=8, data=bytes(32))
    with pytest.raises(UnsupportedEncoding, match='no_such_encoding'):
        conv.convert(m)
    short = Image(height=4, width=8, encoding='rgb8', step=24, data=bytes(10))
    with pytest.raises(UnsupportedEncoding, match='data has 10 bytes'):
        conv.convert(short)


def test_bad_arguments():
    with pytest.raises(ValueError, match='pixel_format'):
        yuv.Converter(8, 4, 'nv12')
    with pytest.raises(ValueError, match='positive'):
        yuv.Converter(0, 4)
    with pytest.raises(ValueError, match='HxWx3'):
        yuv.yuv444_int(np.zeros((4, 4), np.uint8))
