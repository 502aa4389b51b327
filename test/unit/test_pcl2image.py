"""pcl2image: PointCloud2 parsing and offscreen point rendering (no roscore).

Expected pixels are computed here by hand from the pinhole model (u = fx x/z + cx with
f = w / (2 tan(hfov/2)), pixel centres at integers), not with the renderer's own code."""
import math

import numpy as np
import pytest
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import Header

from kinect4skype.cloud import UnsupportedCloud, arrays_to_cloud, cloud_to_arrays
from kinect4skype.node import Pcl2Image
from kinect4skype.render import PointCloudRenderer, viewpoint_from_list
from sim_world.transforms import Pose, quat_from_rpy

W, H = 160, 120
HFOV = math.radians(60)
F = W / (2 * math.tan(HFOV / 2))
CX, CY = (W - 1) / 2.0, (H - 1) / 2.0


def expected_pixel(p_opt):
    x, y, z = p_opt
    return F * x / z + CX, F * y / z + CY


def lit(img):
    return np.argwhere(img.any(axis=2))


# --- parsing -------------------------------------------------------------------------
def cloud(fields, rows, point_step, height=1, row_step=None, big=False, dtype=None):
    m = PointCloud2()
    m.fields = [PointField(name=n, offset=o, datatype=t, count=c) for n, o, t, c in fields]
    m.height = height
    m.width = len(rows) // height
    m.point_step = point_step
    m.row_step = row_step or point_step * m.width
    m.is_bigendian = big
    m.data = b''.join(rows)
    return m


def test_roundtrip_xyz_rgb():
    xyz = np.array([[1, 2, 3], [-1, 0.5, 2]], np.float32)
    rgb = np.array([[255, 0, 10], [1, 2, 3]], np.uint8)
    x2, c2 = cloud_to_arrays(arrays_to_cloud(xyz, rgb))
    assert np.array_equal(x2, xyz) and np.array_equal(c2, rgb)
    x3, c3 = cloud_to_arrays(arrays_to_cloud(xyz))
    assert np.array_equal(x3, xyz) and c3 is None


def test_float64_bigendian_padding_and_uint32_rgb():
    F8, U4 = PointField.FLOAT64, PointField.UINT32
    rows = []
    for p, c in (((1.5, -2.0, 3.25), 0x00ff8001), ((0.0, 1.0, 2.0), 0x00010203)):
        rows.append(np.array(p, '>f8').tobytes() + b'\0' * 4 + np.array([c], '>u4').tobytes()
                    + b'\0' * 4)
    m = cloud([('x', 0, F8, 1), ('y', 8, F8, 1), ('z', 16, F8, 1), ('rgb', 28, U4, 1)],
              rows, 36, big=True)
    xyz, rgb = cloud_to_arrays(m)
    assert np.allclose(xyz, [[1.5, -2.0, 3.25], [0, 1, 2]])
    assert rgb.tolist() == [[255, 128, 1], [1, 2, 3]]


def test_organized_cloud_with_nans_and_row_padding():
    F4 = PointField.FLOAT32
    pts = np.array([[[0, 0, 1], [np.nan, np.nan, np.nan]], [[1, 1, 2], [2, 2, np.inf]]],
                   np.float32)
    rows = [r.tobytes() + b'\xee' * 8 for r in pts]            # 8 bytes of row padding
    m = cloud([('x', 0, F4, 1), ('y', 4, F4, 1), ('z', 8, F4, 1)], [], 12)
    m.height, m.width, m.row_step, m.data = 2, 2, 32, b''.join(rows)
    xyz, rgb = cloud_to_arrays(m)
    assert xyz.tolist() == [[0, 0, 1], [1, 1, 2]] and rgb is None


def test_sim_camera_points_parse():
    from simvid.camera_model import point_cloud2
    xyz = np.zeros((2, 3, 3), np.float32)
    xyz[..., 2] = 1.0
    xyz[0, 1] = np.nan
    rgb = np.full((2, 3, 3), 7, np.uint8)
    out_xyz, out_rgb = cloud_to_arrays(point_cloud2(xyz, rgb))
    assert out_xyz.shape == (5, 3) and (out_rgb == 7).all()


@pytest.mark.parametrize('fields,step,needle', [
    ([('x', 0, PointField.FLOAT32, 1), ('y', 4, PointField.FLOAT32, 1)], 8, 'no z field'),
    ([('x', 0, PointField.INT16, 1), ('y', 2, PointField.INT16, 1), ('z', 4, PointField.INT16, 1)],
     6, 'field x is INT16'),
    ([('x', 0, PointField.FLOAT32, 1), ('y', 4, PointField.FLOAT32, 1),
      ('z', 8, PointField.FLOAT32, 1), ('rgb', 12, PointField.UINT8, 3)], 16,
     'colour field rgb is UINT8 x3'),
    ([('x', 0, PointField.FLOAT32, 1), ('y', 4, PointField.FLOAT32, 1),
      ('z', 8, PointField.FLOAT32, 1)], 10, 'does not fit point_step'),
])
def test_unsupported_layouts_are_named(fields, step, needle):
    m = cloud(fields, [b'\0' * step] * 3, step)
    with pytest.raises(UnsupportedCloud) as e:
        cloud_to_arrays(m)
    assert needle in str(e.value)


def test_truncated_data_is_reported():
    m = arrays_to_cloud(np.zeros((4, 3), np.float32))
    m.data = m.data[:-5]
    with pytest.raises(UnsupportedCloud, match='data has 43 bytes'):
        cloud_to_arrays(m)


# --- rendering ---------------------------------------------------------------------------
@pytest.fixture(scope='module')
def r1():
    return PointCloudRenderer(W, H, HFOV, point_size=1.0)


def test_single_coloured_point_lands_on_expected_pixel(r1):
    r1.set_viewpoint(Pose())
    p = (0.4, -0.25, 2.0)
    img = r1.render(np.array([p], np.float32), np.array([[255, 40, 10]], np.uint8))
    assert img.shape == (H, W, 3)
    u, v = expected_pixel(p)
    hits = lit(img)
    assert len(hits) == 1, hits
    assert tuple(hits[0]) == (round(v), round(u))
    assert img[round(v), round(u)].tolist() == [255, 40, 10]


def test_point_with_moved_and_turned_viewpoint(r1):
    # camera 1 m to the right (+x), yawed about its y (down) axis by 20 degrees
    vp = viewpoint_from_list([1.0, 0.0, 0.0, 0.0, math.radians(20), 0.0])
    r1.set_viewpoint(vp)
    p_world = np.array([1.6, 0.3, 3.0])
    R = Pose((0, 0, 0), quat_from_rpy(0, math.radians(20), 0)).matrix()[:3, :3]
    p_cam = R.T.dot(p_world - np.array([1.0, 0, 0]))
    u, v = expected_pixel(p_cam)
    img = r1.render(np.array([p_world], np.float32), np.array([[0, 255, 0]], np.uint8))
    hits = lit(img)
    assert len(hits) == 1 and tuple(hits[0]) == (round(v), round(u)), (hits, u, v)
    r1.set_viewpoint(Pose())


def test_point_behind_camera_is_not_drawn(r1):
    r1.set_viewpoint(Pose())
    img = r1.render(np.array([[0, 0, -2]], np.float32), np.array([[255, 255, 255]], np.uint8))
    assert len(lit(img)) == 0


def test_plane_fills_expected_region():
    r = PointCloudRenderer(W, H, HFOV, point_size=2.0, background=(0, 0, 0))
    # a dense 1.0 x 0.5 m rectangle, 2 m in front of the camera, 2 mm spacing
    xs, ys = np.meshgrid(np.arange(-0.5, 0.5 + 1e-9, 0.002), np.arange(-0.25, 0.25 + 1e-9, 0.002))
    xyz = np.c_[xs.ravel(), ys.ravel(), np.full(xs.size, 2.0)].astype(np.float32)
    rgb = np.tile(np.array([[30, 200, 90]], np.uint8), (xyz.shape[0], 1))
    img = r.render(xyz, rgb)
    u0, v0 = expected_pixel((-0.5, -0.25, 2.0))
    u1, v1 = expected_pixel((0.5, 0.25, 2.0))
    filled = img.any(axis=2)
    inner = filled[int(math.ceil(v0)) + 1:int(v1), int(math.ceil(u0)) + 1:int(u1)]
    assert inner.size > 1000 and inner.all(), 'holes inside the plane'
    outer = filled.copy()
    outer[int(v0) - 1:int(math.ceil(v1)) + 2, int(u0) - 1:int(math.ceil(u1)) + 2] = False
    assert not outer.any(), 'points drawn outside the plane'
    assert (img[filled] == [30, 200, 90]).all()


def test_depth_test_and_depth_colour_map(r1):
    r1.set_viewpoint(Pose())
    r1.color_mode = 'depth'
    xyz = np.array([[0, 0, 1.0], [0, 0, 5.0], [0.5, 0, 5.0]], np.float32)
    img, mode = r1.render_cloud(xyz, None)
    assert mode == 'depth'
    c = img[round(CY), round(CX)]          # near point wins over the far one
    far = img[round(expected_pixel((0.5, 0, 5.0))[1]), round(expected_pixel((0.5, 0, 5.0))[0])]
    assert c[0] > 100 and c[2] < 60, c     # near: red end of the map
    assert far[2] > 100 and far[0] < 60, far   # far: blue end
    r1.color_mode = 'auto'


def test_node_logic_reports_bad_cloud_once_and_keeps_serving():
    r = PointCloudRenderer(W, H, HFOV, point_size=1.0)
    published, errors = [], []
    node = Pcl2Image(r, published.append, log_error=errors.append)
    bad = cloud([('x', 0, PointField.FLOAT32, 1), ('y', 4, PointField.FLOAT32, 1)],
                [b'\0' * 8] * 2, 8)
    for _ in range(3):
        assert node.on_cloud(bad) is None
    assert len(errors) == 1 and 'no z field' in errors[0]
    good = arrays_to_cloud(np.array([[0.0, 0.0, 2.0]], np.float32),
                           np.array([[9, 99, 199]], np.uint8), frame_id='cam')
    good.header = Header(frame_id='cam')
    img = node.on_cloud(good)
    assert len(published) == 1 and published[0].encoding == 'rgb8'
    assert published[0].header.frame_id == 'cam'
    assert img[round(CY), round(CX)].tolist() == [9, 99, 199]
    # a new viewpoint re-renders the last cloud: camera 0.5 m left, the point moves right
    from geometry_msgs.msg import Pose as PoseMsg
    pm = PoseMsg()
    pm.position.x = -0.5
    pm.orientation.w = 1.0
    img = node.on_pose(pm)
    u, v = expected_pixel((0.5, 0.0, 2.0))
    assert img[round(v), round(u)].tolist() == [9, 99, 199]
    assert len(published) == 2
    pm.orientation.w = 0.0                   # zero quaternion: rejected, view kept
    assert node.on_pose(pm) is None
    assert len(errors) == 2 and 'viewpoint pose rejected' in errors[1]
