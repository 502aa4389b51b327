"""Camera math (simvid.camera_model): focal length from hfov (thesis table 4.1), camera_info
matrices, distortion applied to the image and undone by OpenCV with the published K and D,
point clouds from depth. The GL parts render tiny scenes through the shared OSMesa context."""
import math
import struct

import cv2
import numpy as np
import pytest

from simvid.camera_model import (CameraModelError, Distorter, Intrinsics, SimCamera,
                                 camera_info, focal_from_hfov, hfov_from_focal, pack_rgb,
                                 points_from_depth, point_cloud2, distort_normalized,
                                 undistort_normalized)
from sim_world.model import Geometry, Link, Material, Model, Visual
from sim_world.render import Renderer
from sim_world.transforms import Pose


def test_focal_length_formula_of_the_thesis():
    # f = width / (2 tan(hfov/2)): 480 px at 60 degrees
    assert focal_from_hfov(480, math.radians(60)) == pytest.approx(480 / (2 * math.tan(math.pi / 6)))
    assert focal_from_hfov(480, math.radians(60)) == pytest.approx(415.692, abs=1e-3)
    assert focal_from_hfov(640, math.radians(90)) == pytest.approx(320.0)
    assert hfov_from_focal(640, 320.0) == pytest.approx(math.radians(90))
    for bad in (0.0, -0.1, math.pi, 4.0, float('nan')):
        with pytest.raises(CameraModelError):
            focal_from_hfov(480, bad)


def test_intrinsics_square_pixels_vertical_fov_and_principal_point():
    i = Intrinsics(480, 800, math.radians(60))
    assert i.fx == i.fy
    assert (i.cx, i.cy) == (239.5, 399.5)          # centre, OpenCV pixel convention
    # vertical FOV follows from the aspect ratio
    assert i.vfov == pytest.approx(2 * math.atan(800 / 480 * math.tan(math.radians(30))))
    j = Intrinsics(480, 800, math.radians(60), focal_length=500.0, cx=200, cy=300)
    assert (j.fx, j.fy, j.cx, j.cy) == (500.0, 500.0, 200.0, 300.0)
    assert j.hfov == pytest.approx(2 * math.atan(240 / 500.0))
    with pytest.raises(CameraModelError, match='focal_length'):
        Intrinsics(480, 800, 1.0, focal_length=-3)
    with pytest.raises(CameraModelError, match='size'):
        Intrinsics(0, 800)
    with pytest.raises(CameraModelError, match='finite'):
        Intrinsics(480, 800, 1.0, cx=float('inf'))


def test_camera_info_matrices():
    i = Intrinsics(640, 480, math.radians(90), distortion=(-0.2, 0.05, 0.001, -0.002, 0.01))
    msg = camera_info(i, frame_id='cam')
    assert (msg.width, msg.height, msg.header.frame_id) == (640, 480, 'cam')
    assert msg.distortion_model == 'plumb_bob'
    assert list(msg.D) == [-0.2, 0.05, 0.001, -0.002, 0.01]     # k1 k2 t1 t2 k3
    assert list(msg.K) == pytest.approx([320, 0, 319.5, 0, 320, 239.5, 0, 0, 1])
    assert list(msg.R) == [1, 0, 0, 0, 1, 0, 0, 0, 1]
    assert list(msg.P) == pytest.approx([320, 0, 319.5, 0, 0, 320, 239.5, 0, 0, 0, 1, 0])
    # a point in the optical frame projects with K as OpenCV does
    uv = i.project([[0.5, -0.25, 2.0]])[0]
    ref, _ = cv2.projectPoints(np.array([[0.5, -0.25, 2.0]]), np.zeros(3), np.zeros(3),
                               np.array(msg.K).reshape(3, 3), np.array(msg.D))
    assert np.allclose(uv, ref.reshape(2))


@pytest.mark.parametrize('D', [(-0.25, 0.06, 0.0, 0.0, 0.0), (0.15, 0.02, 0.0, 0.0, 0.0),
                               (-0.1, 0.01, 0.002, -0.003, 0.001)])
def test_undistort_inverts_distort(D):
    x, y = np.meshgrid(np.linspace(-0.6, 0.6, 25), np.linspace(-0.4, 0.4, 17))
    xd, yd = distort_normalized(x, y, D)
    xu, yu, ok = undistort_normalized(xd, yd, D)
    assert ok.all()
    assert np.abs(xu - x).max() < 1e-9 and np.abs(yu - y).max() < 1e-9


def _blobs(shape, points, sigma=1.6):
    """Float image with Gaussian dots at sub-pixel positions."""
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w]
    img = np.zeros((h, w), np.float32)
    for (u, v) in points:
        img += np.exp(-((xx - u) ** 2 + (yy - v) ** 2) / (2 * sigma ** 2))
    return img


def _centroids(img, points, r=6):
    out = []
    for (u, v) in points:
        u0, v0 = int(round(u)), int(round(v))
        patch = img[max(v0 - r, 0):v0 + r + 1, max(u0 - r, 0):u0 + r + 1].astype(float)
        patch = np.where(patch > 0.05 * patch.max(), patch, 0)
        yy, xx = np.mgrid[max(v0 - r, 0):v0 + r + 1, max(u0 - r, 0):u0 + r + 1]
        out.append(((patch * xx).sum() / patch.sum(), (patch * yy).sum() / patch.sum()))
    return np.array(out)


@pytest.mark.parametrize('D', [(-0.3, 0.08, 0.0, 0.0, 0.0),        # barrel
                               (0.2, 0.05, 0.0, 0.0, 0.0),         # pincushion
                               (-0.15, 0.02, 0.003, -0.002, 0.0)])  # with tangential terms
def test_distortion_round_trip_with_opencv(D):
    """Distort an image of dots whose ideal pinhole pixels are known; OpenCV's
    undistortPoints with the published K and D brings every dot back within 0.5 px."""
    intr = Intrinsics(320, 240, math.radians(70), distortion=D)
    dist = Distorter(intr)
    wr, hr, fxr, fyr, cxr, cyr = dist.render_view_params
    # dots on a grid of normalized directions (x/z, y/z) visible in the distorted frame
    gx, gy = np.meshgrid(np.linspace(-0.55, 0.55, 7), np.linspace(-0.38, 0.38, 5))
    rays = np.stack([gx.ravel(), gy.ravel()], axis=1)
    src = [(fxr * x + cxr, fyr * y + cyr) for x, y in rays]       # in the render image
    ideal = np.array([(intr.fx * x + intr.cx, intr.fy * y + intr.cy) for x, y in rays])
    img = _blobs((hr, wr), src)
    out = dist.apply(img)
    assert out.shape == (240, 320)
    # where OpenCV's forward model puts each dot in the distorted image
    pred = intr.project(np.c_[rays, np.ones(len(rays))])
    inside = (pred[:, 0] > 8) & (pred[:, 0] < 312) & (pred[:, 1] > 8) & (pred[:, 1] < 232)
    assert inside.sum() >= 20
    found = _centroids(out, pred[inside])
    assert np.abs(found - pred[inside]).max() < 0.5              # dots where D says
    K = intr.K()
    back = cv2.undistortPoints(found.reshape(-1, 1, 2), K, intr.D, P=K).reshape(-1, 2)
    err = np.abs(back - ideal[inside]).max()
    assert err < 0.5, err
    # the distortion is real: without undoing it the dots are far from the ideal pixels
    assert np.abs(found - ideal[inside]).max() > 3.0


def test_no_distortion_is_identity():
    d = Distorter(Intrinsics(64, 48, 1.0))
    assert d.identity and d.render_view_params[:2] == (64, 48)
    img = np.random.RandomState(1).randint(0, 255, (48, 64, 3)).astype(np.uint8)
    assert d.apply(img) is img


def _edge_world():
    # a big white plate with a black vertical half, 2 m ahead: one straight vertical edge
    # well off the image centre (where barrel distortion bends lines most)
    white = Material((1, 1, 1, 1), lit=False, name='w')
    black = Material((0, 0, 0, 1), lit=False, name='b')
    links = {'p': Link('p', visuals=[
        Visual(Geometry('box', size=(0.01, 8, 8)), material=white),
        Visual(Geometry('box', size=(0.01, 4, 8)), origin=Pose((-0.01, -2.0 - 0.6, 0)),
               material=black)])}
    return Model('plate', links=links, pose=Pose((2.0, 0, 0)))


def _edge_columns(img):
    """Sub-pixel column of the dark->bright... edge in every row (grey image)."""
    g = img.astype(float)
    if g.ndim == 3:
        g = g.mean(axis=2)
    cols = []
    for row in g:
        d = np.abs(np.diff(row))
        i = int(d.argmax())
        lo, hi = max(i - 3, 0), min(i + 4, len(d))
        w = d[lo:hi]
        cols.append((w * (np.arange(lo, hi) + 0.5)).sum() / w.sum())
    return np.array(cols)


def test_rendered_straight_edge_is_bent_then_straightened_by_cv2_undistort():
    r = Renderer()
    r.add_model(_edge_world())
    cam = SimCamera(320, 240, math.radians(80), distortion=(-0.3, 0.09, 0, 0, 0),
                    background=(0.5, 0.5, 0.5))
    rgb, _ = cam.render(r, Pose())
    assert rgb.shape == (240, 320, 3)
    cols = _edge_columns(rgb[10:-10])
    rows = np.arange(10, 230)
    bent = np.polyfit(rows, cols, 1, full=True)
    dev_bent = np.abs(cols - np.polyval(bent[0], rows)).max()
    assert dev_bent > 3.0                            # the lens bends the edge
    K, D = cam.intr.K(), cam.intr.D
    straight = cv2.undistort(rgb, K, D)
    cols2 = _edge_columns(straight[20:-20])
    rows2 = np.arange(20, 220)
    fit = np.polyfit(rows2, cols2, 1)
    dev = np.abs(cols2 - np.polyval(fit, rows2)).max()
    assert dev < 0.5, dev
    # and it is where the pinhole model puts it: the black half's front face is 1.985 m
    # ahead and its edge 0.6 m right of the axis (y = -0.6)
    u_pred = cam.intr.cx + cam.intr.fx * 0.6 / 1.985
    assert abs(np.polyval(fit, 120) - u_pred) < 1.0


def test_points_from_depth_and_pointcloud2():
    intr = Intrinsics(8, 6, math.radians(90))
    d = Distorter(intr)
    depth = np.full((6, 8), 2.0, np.float32)
    depth[0, 0] = np.inf
    xyz = points_from_depth(depth, d.rays)
    assert np.isnan(xyz[0, 0]).all()
    u, v = 5, 4
    assert np.allclose(xyz[v, u], [(u - intr.cx) / intr.fx * 2, (v - intr.cy) / intr.fy * 2, 2.0])
    rgb = np.zeros((6, 8, 3), np.uint8)
    rgb[v, u] = (10, 20, 30)
    msg = point_cloud2(xyz, rgb, frame_id='cam')
    assert (msg.height, msg.width, msg.point_step, msg.row_step) == (6, 8, 16, 128)
    assert [f.name for f in msg.fields] == ['x', 'y', 'z', 'rgb'] and not msg.is_dense
    from sensor_msgs import point_cloud2 as pc2
    pts = list(pc2.read_points(msg, field_names=('x', 'y', 'z', 'rgb'), skip_nans=False))
    x, y, z, packed = pts[v * 8 + u]
    assert (x, y, z) == pytest.approx(tuple(xyz[v, u]))
    bits = struct.unpack('<I', struct.pack('<f', packed))[0]
    assert ((bits >> 16) & 255, (bits >> 8) & 255, bits & 255) == (10, 20, 30)
    assert pack_rgb(np.array([[[1, 2, 3]]], np.uint8)).view(np.uint32)[0, 0] == 0x010203


def test_sim_camera_cloud_of_a_rendered_wall():
    r = Renderer()
    r.add_model(Model('wall', links={'w': Link('w', visuals=[
        Visual(Geometry('box', size=(0.1, 10, 10)), material=Material((1, 0, 0, 1), lit=False))])},
        pose=Pose((3.05, 0, 0))))
    for D in ((0, 0, 0, 0, 0), (-0.2, 0.03, 0, 0, 0)):
        cam = SimCamera(40, 30, math.radians(60), distortion=D)
        rgb, depth = cam.render(r, Pose(), depth=True)
        assert depth.shape == (30, 40)
        msg = cam.cloud_msg(rgb, depth, frame_id='c')
        pts = np.frombuffer(msg.data, np.float32).reshape(30, 40, 4)
        assert np.allclose(pts[:, :, 2], 3.0, atol=0.01)        # the wall is 3 m ahead
        # x grows to the right (optical frame), y down
        assert pts[15, 39, 0] > 0 > pts[15, 0, 0] and pts[29, 20, 1] > 0 > pts[0, 20, 1]


def test_set_hfov_changes_focal_and_zooms():
    cam = SimCamera(100, 80, math.radians(60))
    f0 = cam.intr.fx
    cam.set_hfov(math.radians(30))
    assert cam.intr.fx == pytest.approx(50 / math.tan(math.radians(15)))
    assert cam.intr.fx > f0
    with pytest.raises(CameraModelError):
        cam.set_hfov(-1.0)
    assert cam.hfov == pytest.approx(math.radians(30))          # unchanged after a bad value
