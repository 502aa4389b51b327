"""sensor_msgs/PointCloud2 <-> numpy for pcl2image.

Supported layouts: fields x, y, z (FLOAT32 or FLOAT64, count 1, any offsets and
point_step, either byte order), optionally a colour field ``rgb`` or ``rgba`` (PCL's packed
0x00RRGGBB in a FLOAT32 or UINT32, as the sim camera's ``points`` and the Kinect publish).
Every other layout raises ``UnsupportedCloud`` whose message names what is wrong.
Points with a NaN or infinite coordinate (no return) are dropped.
"""
import numpy as np

__all__ = ['UnsupportedCloud', 'cloud_to_arrays', 'arrays_to_cloud', 'synthetic_cloud']

# sensor_msgs/PointField datatypes
INT8, UINT8, INT16, UINT16, INT32, UINT32, FLOAT32, FLOAT64 = range(1, 9)
_TYPE_NAMES = {INT8: 'INT8', UINT8: 'UINT8', INT16: 'INT16', UINT16: 'UINT16',
               INT32: 'INT32', UINT32: 'UINT32', FLOAT32: 'FLOAT32', FLOAT64: 'FLOAT64'}
_SIZES = {INT8: 1, UINT8: 1, INT16: 2, UINT16: 2, INT32: 4, UINT32: 4, FLOAT32: 4, FLOAT64: 8}


class UnsupportedCloud(ValueError):
    """The PointCloud2 cannot be drawn; the message says why."""


def _layout(fields):
    return ', '.join('%s:%s@%d' % (f.name, _TYPE_NAMES.get(f.datatype, 'type%d' % f.datatype),
                                   f.offset) for f in fields) or 'no fields'


def cloud_to_arrays(msg):
    """PointCloud2 -> (xyz Nx3 float32, rgb Nx3 uint8 or None), finite points only."""
    fields = {f.name: f for f in msg.fields}
    missing = [n for n in 'xyz' if n not in fields]
    if missing:
        raise UnsupportedCloud('point cloud has no %s field (fields: %s); pcl2image needs '
                               'x, y, z with optional rgb' % ('/'.join(missing), _layout(msg.fields)))
    n = msg.width * msg.height
    step = msg.point_step
    if n == 0:
        return np.zeros((0, 3), np.float32), None
    if step <= 0:
        raise UnsupportedCloud('point cloud has point_step %d' % step)
    if msg.height > 1 and msg.row_step < msg.width * step:
        raise UnsupportedCloud('point cloud row_step %d < width %d x point_step %d'
                               % (msg.row_step, msg.width, step))
    row_step = msg.row_step if msg.height > 1 else msg.width * step
    need = (msg.height - 1) * row_step + msg.width * step
    if len(msg.data) < need:
        raise UnsupportedCloud('point cloud data has %d bytes, %dx%d points of %d bytes need %d'
                               % (len(msg.data), msg.width, msg.height, step, need))
    order = '>' if msg.is_bigendian else '<'
    ftypes = []
    for name in 'xyz':
        f = fields[name]
        if f.datatype not in (FLOAT32, FLOAT64) or f.count not in (0, 1):
            raise UnsupportedCloud('point cloud field %s is %s x%d; pcl2image needs FLOAT32 or '
                                   'FLOAT64 x1 coordinates (fields: %s)'
                                   % (name, _TYPE_NAMES.get(f.datatype, f.datatype), f.count,
                                      _layout(msg.fields)))
        if f.offset + _SIZES[f.datatype] > step:
            raise UnsupportedCloud('point cloud field %s at offset %d does not fit point_step %d'
                                   % (name, f.offset, step))
        ftypes.append((name, f))
    cf = fields.get('rgb') or fields.get('rgba')
    if cf is not None:
        if cf.datatype not in (FLOAT32, UINT32, INT32) or cf.count not in (0, 1) \
                or cf.offset + 4 > step:
            raise UnsupportedCloud('point cloud colour field %s is %s x%d at offset %d; pcl2image '
                                   'reads packed 0x00RRGGBB in a FLOAT32 or UINT32'
                                   % (cf.name, _TYPE_NAMES.get(cf.datatype, cf.datatype),
                                      cf.count, cf.offset))
    buf = np.frombuffer(msg.data, np.uint8)
    if msg.height > 1 and row_step != msg.width * step:
        rows = buf[:msg.height * row_step].reshape(msg.height, row_step)[:, :msg.width * step]
        buf = np.ascontiguousarray(rows).reshape(-1)
    # one structured view over the points: each field read is a single strided copy
    names, formats, offsets = [], [], []
    for name, f in ftypes:
        names.append(name)
        formats.append(order + ('f4' if f.datatype == FLOAT32 else 'f8'))
        offsets.append(f.offset)
    if cf is not None:
        names.append('c')
        formats.append(order + 'u4')
        offsets.append(cf.offset)
    dt = np.dtype({'names': names, 'formats': formats, 'offsets': offsets, 'itemsize': step})
    pts = np.frombuffer(buf, dt, count=n)
    xyz = np.empty((n, 3), np.float32)
    xyz[:, 0] = pts['x']
    xyz[:, 1] = pts['y']
    xyz[:, 2] = pts['z']
    # NaN/inf in any coordinate makes the row sum non-finite; numpy's all(axis=1) over an
    # Nx3 mask is several times slower than this matrix-vector product
    good = np.isfinite(xyz.dot(np.ones(3, np.float32)))
    rgb = None
    if cf is not None:
        # 0x00RRGGBB -> bytes R, G, B
        packed = pts['c'].astype('<u4')
        rgb = packed.view(np.uint8).reshape(n, 4)[:, 2::-1]
    if not good.all():
        xyz = xyz[good]
        if rgb is not None:
            rgb = rgb[good]
    if rgb is not None:
        rgb = np.ascontiguousarray(rgb)
    return xyz, rgb


def arrays_to_cloud(xyz, rgb=None, frame_id='', stamp=None):
    """Nx3 points (+ Nx3 uint8 colours) -> unorganized PointCloud2 x y z [rgb] FLOAT32."""
    from sensor_msgs.msg import PointCloud2, PointField
    xyz = np.asarray(xyz, np.float32).reshape(-1, 3)
    n = xyz.shape[0]
    cols = 4 if rgb is not None else 3
    buf = np.empty((n, cols), np.float32)
    buf[:, :3] = xyz
    if rgb is not None:
        c = np.asarray(rgb, np.uint8).reshape(-1, 3).astype(np.uint32)
        buf[:, 3] = ((c[:, 0] << 16) | (c[:, 1] << 8) | c[:, 2]).view(np.float32)
    msg = PointCloud2()
    msg.header.frame_id = frame_id
    if stamp is not None:
        msg.header.stamp = stamp
    msg.height, msg.width = 1, n
    names = ['x', 'y', 'z', 'rgb'][:cols]
    msg.fields = [PointField(name=nm, offset=4 * i, datatype=PointField.FLOAT32, count=1)
                  for i, nm in enumerate(names)]
    msg.is_bigendian = False
    msg.point_step = 4 * cols
    msg.row_step = msg.point_step * n
    msg.is_dense = True
    msg.data = buf.tobytes()
    return msg


def synthetic_cloud(n, seed=0, colored=True):
    """A Kinect-like scene in the optical frame (z forward): a coloured wall 3 m away
    and a sphere in front of it, ``n`` points in total (benchmarks and the demo source)."""
    rng = np.random.RandomState(seed)
    n_s = n // 3
    n_w = n - n_s
    wall = np.c_[rng.uniform(-2.0, 2.0, n_w), rng.uniform(-1.5, 1.5, n_w), np.full(n_w, 3.0)]
    d = rng.normal(size=(n_s, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    sphere = d * 0.5 + np.array([0.0, 0.0, 1.8])
    xyz = np.vstack([wall, sphere]).astype(np.float32)
    if not colored:
        return xyz, None
    rgb = np.empty((n, 3), np.uint8)
    rgb[:n_w, 0] = ((wall[:, 0] + 2.0) * 60).astype(np.uint8)
    rgb[:n_w, 1] = ((wall[:, 1] + 1.5) * 80).astype(np.uint8)
    rgb[:n_w, 2] = 160
    rgb[n_w:] = (230, 60, 40)
    return xyz, rgb
