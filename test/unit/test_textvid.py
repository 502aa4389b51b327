"""Video texture (textvid.video): conversions, default, bad input, scaling, plugin params.
No roscore: the plugin runs with a world whose ros_enabled is False and a recording renderer."""
import logging
import threading
import time
import xml.etree.ElementTree as ET

import cv2
import numpy as np
import pytest
from sensor_msgs.msg import Image

from sim_world import plugins
from simvid.imageconv import array_to_image
from sim_world.model import Geometry, Link, Model, PluginSpec, Visual
from textvid import video
from textvid.video import BLUE, VideoPlugin, VideoTexture

# a 2x3 picture with six different colours (rows top to bottom)
RGB = np.array([[[255, 0, 0], [0, 255, 0], [0, 0, 255]],
                [[255, 255, 0], [0, 255, 255], [40, 80, 120]]], np.uint8)


def _tex(w=3, h=2):
    lines = []
    return VideoTexture(w, h, name='tv', logger=lines.append), lines


# --- default and encodings -----------------------------------------------------------------
def test_blue_until_the_first_image():
    tex, lines = _tex(64, 32)
    img = tex.image
    assert img.shape == (32, 64, 3) and img.dtype == np.uint8
    assert (img == np.array(BLUE, np.uint8)).all()
    assert BLUE == (0, 0, 255)
    first = tex.take()
    assert first is not None and (first == BLUE).all()   # the blue picture is uploaded once
    assert tex.take() is None
    assert lines == [] and tex.source == 'default'


def _encode(encoding):
    rgb = RGB
    return {
        'rgb8': rgb, 'bgr8': rgb[:, :, ::-1], '8UC3': rgb[:, :, ::-1], '8SC3': rgb[:, :, ::-1],
        'rgba8': np.dstack([rgb, np.full(rgb.shape[:2], 9, np.uint8)]),
        'bgra8': np.dstack([rgb[:, :, ::-1], np.full(rgb.shape[:2], 200, np.uint8)]),
        '8UC4': np.dstack([rgb[:, :, ::-1], np.full(rgb.shape[:2], 200, np.uint8)]),
    }[encoding]


@pytest.mark.parametrize('encoding', ['rgb8', 'bgr8', 'rgba8', 'bgra8', '8UC3', '8UC4', '8SC3'])
def test_colour_encodings_arrive_as_rgb(encoding):
    tex, lines = _tex()
    tex.take()
    assert tex.set_image_msg(array_to_image(_encode(encoding), encoding))
    out = tex.take()
    assert out is not None and np.array_equal(out, RGB), (encoding, out)
    assert lines == [] and tex.source == 'topic' and tex.frames == 1


@pytest.mark.parametrize('encoding', ['mono8', '8UC1'])
def test_mono_is_gray(encoding):
    tex, lines = _tex()
    gray = np.array([[0, 50, 100], [150, 200, 255]], np.uint8)
    assert tex.set_image_msg(array_to_image(gray, encoding))
    out = tex.image
    assert np.array_equal(out, np.dstack([gray] * 3))
    assert lines == []


def test_padded_rows_are_handled():
    tex, _ = _tex()
    rows = [bytes(RGB[r].tobytes()) + b'\xee' * 7 for r in range(2)]
    msg = Image(height=2, width=3, encoding='rgb8', step=9 + 7, data=b''.join(rows))
    assert tex.set_image_msg(msg)
    assert np.array_equal(tex.image, RGB)


@pytest.mark.parametrize('encoding', ['16UC1', 'mono16', 'yuv422', 'bayer_rggb8', 'rgb16',
                                      '32FC1', 'nonsense', ''])
def test_other_encodings_are_rejected_and_the_last_image_stays(encoding):
    tex, lines = _tex()
    assert tex.set_image_msg(array_to_image(RGB, 'rgb8'))
    tex.take()
    msg = Image(height=2, width=3, encoding=encoding, step=12, data=bytes(range(24)))
    assert tex.set_image_msg(msg) is False
    assert np.array_equal(tex.image, RGB)          # last image stays
    assert tex.take() is None                       # nothing new to upload
    assert len(lines) == 1 and repr(encoding) in lines[0] and 'tv' in lines[0]
    assert tex.errors == 1 and tex.frames == 1


def test_truncated_image_is_rejected_and_the_last_image_stays():
    tex, lines = _tex()
    tex.set_image_msg(array_to_image(RGB, 'rgb8'))
    short = Image(height=2, width=3, encoding='rgb8', step=9, data=bytes(10))
    assert tex.set_image_msg(short) is False
    empty = Image(height=0, width=0, encoding='bgr8', step=0, data=b'')
    assert tex.set_image_msg(empty) is False
    assert np.array_equal(tex.image, RGB)
    assert len(lines) == 2 and 'bytes' in lines[0] and 'empty' in lines[1]


def test_wrong_channel_count_array_is_rejected():
    tex, lines = _tex()
    assert tex.set_array(RGB, 'rgba8') is False
    assert tex.set_array(RGB[:, :, 0], 'bgr8') is False
    assert tex.set_array(RGB.astype(np.float32), 'rgb8') is False
    assert (tex.image == BLUE).all()
    assert len(lines) == 3 and "3 channels cannot be 'rgba8'" in lines[0]
    assert "1 channels cannot be 'bgr8'" in lines[1] and '8-bit' in lines[2]


# --- files -----------------------------------------------------------------------------------
@pytest.mark.parametrize('ext', ['.png', '.bmp', '.tiff', '.ppm', '.webp'])
def test_lossless_files_load_exactly(tmp_path, ext):
    path = str(tmp_path / ('pic' + ext))
    params = [cv2.IMWRITE_WEBP_QUALITY, 101] if ext == '.webp' else []
    assert cv2.imwrite(path, RGB[:, :, ::-1], params)
    tex, lines = _tex()
    assert tex.load_file(path)
    assert np.array_equal(tex.image, RGB), ext
    assert lines == [] and tex.source == 'file:' + path


def test_jpeg_gray_alpha_and_16bit_files(tmp_path):
    big = cv2.resize(RGB, (60, 40), interpolation=cv2.INTER_NEAREST)
    tex, lines = _tex(60, 40)
    jpg = str(tmp_path / 'a.jpg')
    cv2.imwrite(jpg, big[:, :, ::-1], [cv2.IMWRITE_JPEG_QUALITY, 95])
    assert tex.load_file(jpg)
    assert np.abs(tex.image.astype(int) - big).mean() < 6
    gray = str(tmp_path / 'g.png')
    cv2.imwrite(gray, np.full((40, 60), 77, np.uint8))
    assert tex.load_file(gray) and (tex.image == 77).all()
    rgba = str(tmp_path / 'rgba.png')
    cv2.imwrite(rgba, np.dstack([big[:, :, ::-1], np.zeros((40, 60), np.uint8)]))
    assert tex.load_file(rgba) and np.array_equal(tex.image, big)
    deep = str(tmp_path / 'd.png')
    ramp = np.tile(np.linspace(0, 65535, 60).astype(np.uint16), (40, 1))
    cv2.imwrite(deep, ramp)
    assert tex.load_file(deep)
    row = tex.image[0, :, 0].astype(int)
    assert row[0] == 0 and row[-1] == 255 and np.all(np.diff(row) >= 0)
    dim = str(tmp_path / 'dim.png')
    cv2.imwrite(dim, np.full((40, 60), 0x4000, np.uint16))     # a quarter of full scale
    assert tex.load_file(dim) and (tex.image == 0x40).all()
    assert lines == []


def test_missing_or_unreadable_file_keeps_the_last_image(tmp_path):
    tex, lines = _tex()
    tex.set_array(RGB, 'rgb8')
    tex.take()
    missing = str(tmp_path / 'nope.png')
    junk = tmp_path / 'junk.png'
    junk.write_bytes(b'this is not a png at all')
    for path in (missing, str(junk), str(tmp_path), ''):
        assert tex.load_file(path) is False, path
        assert np.array_equal(tex.image, RGB)
        assert tex.take() is None
    assert len(lines) == 4
    assert 'nope.png' in lines[0] and 'does not exist' in lines[0]
    assert 'junk.png' in lines[1] and 'cannot read' in lines[1]
    assert all('keeping the last image' in l for l in lines)


def test_file_url_and_home_paths(tmp_path, monkeypatch):
    path = tmp_path / 'u.png'
    cv2.imwrite(str(path), RGB[:, :, ::-1])
    tex, lines = _tex()
    assert tex.load_file('file://' + str(path))
    monkeypatch.setenv('HOME', str(tmp_path))
    assert tex.load_file('~/u.png')
    assert lines == []


# --- scaling ---------------------------------------------------------------------------------
def test_a_phone_sized_image_is_scaled_to_the_texture():
    tex, _ = _tex(512, 512)
    img = np.zeros((800, 480, 3), np.uint8)
    img[:400, :240] = (255, 0, 0)
    img[:400, 240:] = (0, 255, 0)
    img[400:, :240] = (0, 0, 255)
    img[400:, 240:] = (255, 255, 255)
    assert tex.set_array(img, 'rgb8')
    out = tex.image
    assert out.shape == (512, 512, 3)
    assert (out[:250, :250] == (255, 0, 0)).all() and (out[:250, 262:] == (0, 255, 0)).all()
    assert (out[262:, :250] == (0, 0, 255)).all() and (out[262:, 262:] == 255).all()


def test_small_images_are_enlarged():
    tex, _ = _tex(30, 20)
    assert tex.set_array(RGB, 'rgb8')
    out = tex.image
    assert out.shape == (20, 30, 3)
    # each source pixel's centre keeps its colour
    for r in range(2):
        for c in range(3):
            px = out[5 + 10 * r, 5 + 10 * c].astype(int)
            assert np.abs(px - RGB[r, c]).max() <= 30, (r, c, px)


def test_big_images_are_averaged_not_aliased():
    # a 2x2-pixel checkerboard shrunk 3.9x: plain sampling would give black/white moire;
    # averaging gives an even mid gray
    tex, _ = _tex(307, 512)
    yy, xx = np.mgrid[0:2000, 0:1150]
    board = np.where(((yy // 2) + (xx // 2)) % 2 == 0, 255, 0).astype(np.uint8)
    assert tex.set_array(board, 'mono8')
    out = tex.image.astype(int)
    assert out.shape == (512, 307, 3)
    assert abs(out.mean() - 127.5) < 3 and out.std() < 12, (out.mean(), out.std())
    # and a large colour image keeps its colours in the right places
    big = np.zeros((2000, 1200, 3), np.uint8)
    big[:1000] = (200, 10, 10)
    big[1000:] = (10, 10, 200)
    assert tex.set_array(big[:, :, ::-1], 'bgr8')
    out = tex.image
    assert (out[:250] == (200, 10, 10)).all() and (out[262:] == (10, 10, 200)).all()


def test_texture_size_limits():
    with pytest.raises(ValueError):
        VideoTexture(0, 10)
    with pytest.raises(ValueError):
        VideoTexture(10, 100000)


def test_callback_and_render_threads_never_see_a_torn_image():
    tex, lines = _tex(64, 64)
    colours = [np.full((48, 80, 3), v, np.uint8) for v in (10, 120, 250)]
    stop = threading.Event()

    def feed():
        i = 0
        while not stop.is_set():
            tex.set_array(colours[i % 3], 'rgb8')
            i += 1
    t = threading.Thread(target=feed)
    t.start()
    seen = 0
    try:
        deadline = time.monotonic() + 10.0
        while seen < 20 and time.monotonic() < deadline:
            img = tex.take()
            if img is not None:
                seen += 1
                assert len(np.unique(img)) == 1 or (img == BLUE).all()
    finally:
        stop.set()
        t.join()
    assert seen >= 20 and lines == []


# --- the plugin ------------------------------------------------------------------------------
class RecordingRenderer(object):
    def __init__(self, fail=False):
        self.calls = []
        self.fail = fail

    def set_dynamic_texture(self, model, link, rgb, face='front'):
        if self.fail:
            raise RuntimeError('GL is gone')
        self.calls.append((model, link, None if rgb is None else rgb.copy(), face))


class FakeWorld(object):
    ros_enabled = False
    log = logging.getLogger('test.textvid')

    def __init__(self, renderer=None):
        self.renderer = renderer or RecordingRenderer()
        self.renderer_if_created = self.renderer     # None: like World before a camera
        self.sim_time = 0.0


def _model(name='phone', body_kind='box', ns=''):
    geo = Geometry('box', size=(0.1, 0.06, 0.002)) if body_kind == 'box' else \
        Geometry('cylinder', radius=0.01, length=0.01)
    links = {'base': Link('base', visuals=[Visual(Geometry('box', size=(0.12, 0.06, 0.01)))]),
             'mobile_display': Link('mobile_display', visuals=[Visual(geo)])}
    return Model(name, links=links, robot_namespace=ns)


def _spec(xml):
    el = ET.fromstring('<plugin name="v" filename="libgazebo_ros_video.so">%s</plugin>' % xml)
    return PluginSpec('libgazebo_ros_video.so', 'v', element=el)


def test_registered_under_both_library_names():
    assert plugins.lookup('libgazebo_ros_video.so') is VideoPlugin
    assert plugins.lookup('libgazebo_ros_video_plugin.so') is VideoPlugin


def test_missing_body_name_is_a_clear_error():
    p = VideoPlugin(_spec('<imageTopic>/x</imageTopic>'), _model(), FakeWorld())
    with pytest.raises(plugins.PluginError) as e:
        p.load()
    assert 'bodyName' in str(e.value) and 'missing' in str(e.value)
    assert 'mobile_display' in str(e.value)       # the message lists the links there are


def test_unknown_or_unsuitable_body_is_a_clear_error():
    with pytest.raises(plugins.PluginError) as e:
        VideoPlugin(_spec('<bodyName>screen</bodyName>'), _model(), FakeWorld()).load()
    assert "'screen'" in str(e.value) and "'phone'" in str(e.value)
    with pytest.raises(plugins.PluginError) as e:
        VideoPlugin(_spec('<bodyName>mobile_display</bodyName>'), _model(body_kind='cyl'),
                    FakeWorld()).load()
    assert 'box' in str(e.value)



@pytest.mark.parametrize('xml, line', [
    ('<face>top</face>', "face must be one of front, back, +x, -x, +y, -y, +z, -z, all, got 'top'"),
    ('<textureWidth>12.5</textureWidth>', "textureWidth must be a whole number in [1, 4096], "
                                          "got '12.5'"),
    ('<updateRate>-1</updateRate>', "updateRate must be a number in [0, 1e+06], got '-1'"),
])
def test_bad_values_one_line_and_the_default(xml, line, caplog):
    caplog.set_level(logging.ERROR)
    p = VideoPlugin(_spec('<bodyName>mobile_display</bodyName>' + xml), _model(), FakeWorld())
    p.load()
    lines = [r.getMessage() for r in caplog.records]
    assert lines == ['plugin libgazebo_ros_video.so of model phone: ' + line]
    assert p.face == 'front' and p.update_rate == video.DEFAULT_RATE


def test_create_logs_one_line_and_the_model_keeps_going(caplog):
    caplog.set_level(logging.ERROR)
    model = _model()
    assert plugins.create(_spec(''), model, FakeWorld()) is None
    errors = [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert len(errors) == 1 and 'bodyName' in errors[0].getMessage()
    assert 'libgazebo_ros_video.so' in errors[0].getMessage()


def test_defaults_and_namespace():
    p = plugins.create(_spec('<bodyName>mobile_display</bodyName>'), _model(), FakeWorld())
    assert p.image_topic == '/monitor/image_in' and p.load_topic == '/monitor/load_file'
    assert p.face == 'front' and p.update_rate == video.DEFAULT_RATE
    # the display box is 0.1 (x) by 0.06 (y); on the +z face the image's top is towards +x
    assert (p.texture.width, p.texture.height) == (307, 512)
    q = plugins.create(_spec('<bodyName>mobile_display</bodyName><imageTopic>image_in'
                             '</imageTopic><imageLoad>/abs/load</imageLoad><face>-z</face>'
                             '<textureWidth>480</textureWidth><textureHeight>800'
                             '</textureHeight>'), _model(ns='/mobile_device'), FakeWorld())
    assert q.image_topic == '/mobile_device/image_in' and q.load_topic == '/abs/load'
    assert q.face == '-z' and (q.texture.width, q.texture.height) == (480, 800)


@pytest.mark.parametrize('xml, size', [
    ('', (307, 512)),
    ('<face>back</face>', (307, 512)),
    ('<face>all</face>', (307, 512)),
    ('<face>+x</face>', (512, 17)),            # 0.06 wide, 0.002 high: clamped to 16+ px
    ('<face>-y</face>', (512, 10 + 6)),
    ('<textureWidth>300</textureWidth>', (300, 500)),
    ('<textureHeight>100</textureHeight>', (60, 100)),
    ('<textureWidth>64</textureWidth><textureHeight>64</textureHeight>', (64, 64)),
])
def test_texture_size_follows_the_face(xml, size):
    p = plugins.create(_spec('<bodyName>mobile_display</bodyName>' + xml), _model(),
                       FakeWorld())
    assert (p.texture.width, p.texture.height) == size


def test_thesis_syntax_loads():
    el = ET.fromstring(
        '<gazebo xmlns:controller="c"><controller:gazebo_ros_video name="gazebo_ros_video_'
        'controller" plugin="libgazebo_ros_video.so"><bodyName>mobile_display</bodyName>'
        '<imageTopic>/mobile_device/image_in</imageTopic><imageLoad>/mobile_device/load_file'
        '</imageLoad></controller:gazebo_ros_video></gazebo>')[0]
    spec = PluginSpec('libgazebo_ros_video.so', 'gazebo_ros_video_controller', element=el)
    p = plugins.create(spec, _model(), FakeWorld())
    assert p.body == 'mobile_display' and p.image_topic == '/mobile_device/image_in'
    assert p.load_topic == '/mobile_device/load_file'


def test_update_uploads_blue_then_each_new_image_once():
    world = FakeWorld()
    p = plugins.create(_spec('<bodyName>mobile_display</bodyName><face>+x</face>'
                             '<textureWidth>3</textureWidth><textureHeight>2</textureHeight>'),
                       _model(), world)
    calls = world.renderer.calls
    p.update(0.0)
    assert len(calls) == 1 and calls[0][:2] == ('phone', 'mobile_display')
    assert calls[0][3] == '+x' and (calls[0][2] == BLUE).all()
    p.update(0.01)
    assert len(calls) == 1                       # nothing new
    p.on_image(array_to_image(RGB[:, :, ::-1], 'bgr8'))
    p.on_image(Image(height=2, width=3, encoding='16UC1', step=6, data=bytes(12)))
    p.update(0.02)
    assert len(calls) == 2 and np.array_equal(calls[1][2], RGB)
    p.shutdown()
    assert calls[-1][2] is None                  # back to the material


def test_no_renderer_is_created_for_a_display_nobody_looks_at():
    world = FakeWorld()
    renderer = world.renderer
    world.renderer_if_created = None            # like World before the first camera
    p = plugins.create(_spec('<bodyName>mobile_display</bodyName>'), _model(), world)
    p.on_image(array_to_image(RGB, 'rgb8'))
    p.update(0.0)
    assert renderer.calls == []
    world.renderer_if_created = renderer        # a camera created it: the image follows
    p.update(0.1)
    assert len(renderer.calls) == 1 and renderer.calls[0][2].shape == (512, 307, 3)


def test_load_file_topic_resolves_package_urls(monkeypatch):
    import os
    from std_msgs.msg import String
    from simvid import qrassets
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    monkeypatch.setenv('ROS_PACKAGE_PATH', root)
    model = _model()
    model.base_dir = '/nonexistent'          # found through ROS_PACKAGE_PATH, not by luck
    p = plugins.create(_spec('<bodyName>mobile_display</bodyName>'), model, FakeWorld())
    p.on_load_file(String(data='package://mobile_device_sim/sim_world/worlds/media/'
                               + qrassets.CLOSED_LOOP_FILE))
    assert p.texture.errors == 0 and p.texture.source.startswith('file:' + root)
    p.on_load_file(String(data='  %s  ' % os.path.join(qrassets.MEDIA_DIR,
                                                        qrassets.PAPER_FILE)))
    assert p.texture.errors == 0 and p.texture.source.endswith(qrassets.PAPER_FILE)


def test_two_displays_keep_their_own_images():
    world = FakeWorld()
    m1, m2 = _model('phone1'), _model('phone2')
    xml = '<bodyName>mobile_display</bodyName><imageTopic>/%s/in</imageTopic>' \
          '<textureWidth>3</textureWidth><textureHeight>2</textureHeight>'
    a = plugins.create(_spec(xml % 'a'), m1, world)
    b = plugins.create(_spec(xml % 'b'), m2, world)
    assert a.image_topic != b.image_topic
    a.on_image(array_to_image(RGB, 'rgb8'))
    a.update(0.0)
    b.update(0.0)
    last = {c[0]: c[2] for c in world.renderer.calls}
    assert np.array_equal(last['phone1'], RGB) and (last['phone2'] == BLUE).all()


def test_a_renderer_failure_is_logged_once_and_does_not_raise(caplog):
    caplog.set_level(logging.ERROR)
    world = FakeWorld(RecordingRenderer(fail=True))
    p = plugins.create(_spec('<bodyName>mobile_display</bodyName>'), _model(), world)
    for i in range(3):
        p.on_image(array_to_image(RGB, 'rgb8'))
        p.update(i * 0.1)
    errors = [r.getMessage() for r in caplog.records if 'cannot update' in r.getMessage()]
    assert len(errors) == 1 and 'GL is gone' in errors[0]
