"""Barcode reader logic (simvid.barcode) and the QR assets (simvid.qrassets), no roscore."""
import os

import cv2
import numpy as np
import pytest
from sensor_msgs.msg import Image

from simvid import barcode, qrassets
from simvid.imageconv import array_to_image


def _paper():
    path = os.path.join(qrassets.MEDIA_DIR, qrassets.PAPER_FILE)
    img = cv2.imread(path, cv2.IMREAD_COLOR)
    assert img is not None, 'committed asset %s missing (run tools/make_qr_assets)' % path
    return img[:, :, ::-1].copy()


# --- EAN-13 drawn here from the standard's tables, so zbar's naming can be checked -----------
_L = ['0001101', '0011001', '0010011', '0111101', '0100011', '0110001', '0101111', '0111011',
      '0110111', '0001011']
_G = [''.join('1' if c == '0' else '0' for c in code)[::-1] for code in _L]
_R = [''.join('1' if c == '0' else '0' for c in code) for code in _L]
_PARITY = ['LLLLLL', 'LLGLGG', 'LLGGLG', 'LLGGGL', 'LGLLGG', 'LGGLLG', 'LGGGLL', 'LGLGLG',
           'LGLGGL', 'LGGLGL']


def ean13_checksum(digits12):
    s = sum(int(d) * (3 if i % 2 else 1) for i, d in enumerate(digits12))
    return str((10 - s % 10) % 10)


def ean13_image(digits12, module=3, height=120):
    code = digits12 + ean13_checksum(digits12)
    bits = '101'
    for i, d in enumerate(code[1:7]):
        bits += (_L if _PARITY[int(code[0])][i] == 'L' else _G)[int(d)]
    bits += '01010'
    for d in code[7:]:
        bits += _R[int(d)]
    bits += '101'
    row = np.array([0 if b == '1' else 255 for b in '0' * 11 + bits + '0' * 11], np.uint8)
    return code, np.repeat(np.tile(np.repeat(row, module), (height, 1))[:, :, None], 3, 2)


# --- decoding ------------------------------------------------------------------------------
def test_paper_asset_holds_the_demo_url():
    found = barcode.decode(_paper())
    assert found == [('QR-Code', 'http://vmi.lmt.ei.tum.de')]


def test_closed_loop_asset_holds_a_different_payload():
    img = cv2.imread(os.path.join(qrassets.MEDIA_DIR, qrassets.CLOSED_LOOP_FILE))
    assert img is not None and img.shape == (800, 480, 3)
    found = barcode.decode(img, 'bgr8')
    assert found == [('QR-Code', qrassets.CLOSED_LOOP_PAYLOAD)]
    assert qrassets.CLOSED_LOOP_PAYLOAD != qrassets.DEMO_URL


def test_assets_are_reproducible(tmp_path):
    paths = qrassets.write_assets(str(tmp_path))
    for p in paths:
        new = cv2.imread(p)
        old = cv2.imread(os.path.join(qrassets.MEDIA_DIR, os.path.basename(p)))
        assert new is not None and old is not None
        assert new.shape == old.shape and np.array_equal(new, old), p


def test_paper_is_a4_white_with_quiet_zone():
    paper = _paper()
    h, w = paper.shape[:2]
    assert abs(h / float(w) - 297 / 210.0) < 0.01
    dark = np.where(paper.min(axis=2) < 128)
    # white margins around everything that is printed
    assert dark[0].min() > 0.05 * h and dark[1].min() > 0.05 * w and dark[1].max() < 0.95 * w
    assert (paper > 250).all(axis=2).mean() > 0.7


def _perspective(img, out_size=(480, 640)):
    h, w = img.shape[:2]
    src = np.float32([[0, 0], [w, 0], [w, h], [0, h]])
    ow, oh = out_size
    dst = np.float32([[0.22 * ow, 0.10 * oh], [0.86 * ow, 0.18 * oh], [0.95 * ow, 0.92 * oh],
                      [0.05 * ow, 0.85 * oh]])
    m = cv2.getPerspectiveTransform(src, dst)
    return cv2.warpPerspective(img, m, (ow, oh), flags=cv2.INTER_LINEAR,
                               borderValue=(90, 70, 50))


def test_decodes_a_blurred_perspective_warped_dim_view_of_the_paper():
    view = _perspective(_paper())
    view = cv2.GaussianBlur(view, (5, 5), 1.2)
    view = (view.astype(np.float32) * 0.55 + 20).astype(np.uint8)   # dim desk lighting
    rng = np.random.RandomState(1)
    view = np.clip(view.astype(np.int16) + rng.randint(-12, 13, view.shape), 0, 255)
    view = view.astype(np.uint8)
    assert barcode.decode(view) == [('QR-Code', qrassets.DEMO_URL)]


def test_no_code_in_a_plain_or_destroyed_image():
    assert barcode.decode(np.full((100, 100, 3), 200, np.uint8)) == []
    # heavy blur destroys the code: the decoder must not invent one
    smeared = cv2.GaussianBlur(_perspective(_paper(), (160, 210)), (21, 21), 8)
    assert barcode.decode(smeared) == []


def test_ean13_is_named_ean13():
    code, img = ean13_image('400638133393')
    assert barcode.decode(img) == [('EAN-13', code)]
    assert barcode.format_barcode('EAN-13', code) == 'EAN-13,' + code


def test_symbol_names_are_zbars():
    assert barcode.symbol_name('QRCODE') == 'QR-Code'
    assert barcode.symbol_name('CODE128') == 'CODE-128'
    assert barcode.symbol_name('EAN8') == 'EAN-8'
    assert barcode.symbol_name('I25') == 'I2/5'


def test_format_is_the_thesis_form():
    assert barcode.format_barcode('QR-Code', 'http://vmi.lmt.ei.tum.de') == \
        'QR-Code,http://vmi.lmt.ei.tum.de'
    # data containing commas stays whole after the first comma
    assert barcode.format_barcode('QR-Code', 'a,b').split(',', 1) == ['QR-Code', 'a,b']


# --- throttling ----------------------------------------------------------------------------
def test_throttle_window():
    t = barcode.Throttle(2.0)
    assert t.allow('QR-Code,x', 10.0)
    assert not t.allow('QR-Code,x', 10.5)
    assert not t.allow('QR-Code,x', 11.99)
    assert t.allow('QR-Code,y', 11.0)          # other codes are independent
    assert t.allow('QR-Code,x', 12.0)          # window over
    assert not t.allow('QR-Code,x', 13.0)
    zero = barcode.Throttle(0)
    assert all(zero.allow('k', 1.0) for _ in range(3))


def test_throttle_survives_a_clock_jump_back():
    t = barcode.Throttle(2.0)
    assert t.allow('k', 100.0)
    assert t.allow('k', 5.0)     # time went backwards (sim reset): do not block for 95 s


# --- the reader on image messages ----------------------------------------------------------
@pytest.mark.parametrize('encoding', ['rgb8', 'bgr8', 'rgba8', 'bgra8', 'mono8'])
def test_reader_reads_every_8bit_encoding(encoding):
    rgb = _perspective(_paper())
    conv = {'rgb8': rgb, 'bgr8': rgb[:, :, ::-1],
            'rgba8': np.dstack([rgb, np.full(rgb.shape[:2], 255, np.uint8)]),
            'bgra8': np.dstack([rgb[:, :, ::-1], np.full(rgb.shape[:2], 7, np.uint8)]),
            'mono8': cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)}[encoding]
    reader = barcode.BarcodeReader(throttle=2.0)
    assert reader.process(array_to_image(conv, encoding), 0.0) == \
        ['QR-Code,http://vmi.lmt.ei.tum.de']
    assert reader.problems == 0


def test_reader_throttles_repeats_and_publishes_again_later():
    msg = array_to_image(_perspective(_paper()), 'rgb8')
    reader = barcode.BarcodeReader(throttle=2.0)
    got = [reader.process(msg, t) for t in (0.0, 0.5, 1.0, 1.9, 2.1, 2.5)]
    assert got == [['QR-Code,' + qrassets.DEMO_URL], [], [], [],
                   ['QR-Code,' + qrassets.DEMO_URL], []]


def test_reader_reports_a_bad_encoding_once_and_keeps_working():
    lines = []
    reader = barcode.BarcodeReader(throttle=0, logger=lines.append)
    bad = Image(height=4, width=4, encoding='weird42', step=4, data=bytes(16))
    for _ in range(5):
        assert reader.process(bad, 0.0) == []
    short = Image(height=10, width=10, encoding='rgb8', step=30, data=bytes(20))
    assert reader.process(short, 0.0) == []
    assert reader.problems == 6
    assert len(lines) == 2, lines
    assert 'weird42' in lines[0]
    assert 'rgb8' in lines[1] and 'bytes' in lines[1]
    good = array_to_image(_perspective(_paper()), 'rgb8')
    assert reader.process(good, 1.0) == ['QR-Code,' + qrassets.DEMO_URL]
