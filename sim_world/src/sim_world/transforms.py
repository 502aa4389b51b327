"""Rigid transforms: the pose math every part of the simulator shares.

A ``Pose`` is a position (3 floats, metres) and a unit quaternion in ROS order
(x, y, z, w). ``a * b`` composes like tf2 / Bullet's btTransform: a point p given in
frame b maps to a*(b*p). REP 103: x forward, y left, z up; rpy is fixed-axis
roll (x), pitch (y), yaw (z), as URDF and SDF use it.
"""
import math

import numpy as np

__all__ = ['Pose', 'InvalidPose', 'quat_from_rpy', 'rpy_from_quat', 'quat_multiply',
           'quat_rotate', 'quat_to_matrix', 'quat_to_matrices', 'quat_normalize',
           'matrix_to_quat', 'quat_conjugate']


class InvalidPose(ValueError):
    """A pose with NaN/inf values or a quaternion that cannot be normalised."""


def _floats(q):
    """The numbers of a small vector as Python floats (cheaper arithmetic than numpy scalars)."""
    return q.tolist() if type(q) is np.ndarray else q


def _normalized(x, y, z, w):
    """(x, y, z, w) / norm as a tuple of floats; InvalidPose for NaN/inf or zero."""
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if not math.isfinite(n):
        raise InvalidPose('quaternion %s is not four finite numbers'
                          % ([round(v, 6) for v in (x, y, z, w)],))
    if n < 1e-6:
        raise InvalidPose('quaternion %s cannot be normalised (norm %.3g)' % ([x, y, z, w], n))
    return (x / n, y / n, z / n, w / n)


def quat_normalize(q):
    """Unit quaternion of q (x, y, z, w); InvalidPose for NaN/inf or a zero quaternion.
    Plain float math: this runs several times per world step."""
    try:
        x, y, z, w = (float(v) for v in _floats(q))
    except (TypeError, ValueError):
        raise InvalidPose('quaternion %r is not four numbers' % (q,))
    return np.array(_normalized(x, y, z, w))


def quat_from_rpy(roll, pitch, yaw):
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array([sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy,
                     cr * cp * sy - sr * sp * cy,
                     cr * cp * cy + sr * sp * sy])


def rpy_from_quat(q):
    x, y, z, w = q
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    s = max(-1.0, min(1.0, 2 * (w * y - z * x)))
    pitch = math.asin(s)
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.array([roll, pitch, yaw])


def _quat_multiply(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def quat_multiply(a, b):
    return np.array(_quat_multiply(_floats(a), _floats(b)))


def quat_conjugate(q):
    return np.array([-q[0], -q[1], -q[2], q[3]])


def quat_to_matrix(q):
    x, y, z, w = _floats(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def quat_to_matrices(q):
    """(n, 3, 3) rotation matrices of n quaternions given as rows (x, y, z, w) (the
    renderer's batch of link poses)."""
    q = np.asarray(q, float)
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    m = np.empty((len(q), 3, 3))
    m[:, 0, 0] = 1 - 2 * (y * y + z * z)
    m[:, 0, 1] = 2 * (x * y - z * w)
    m[:, 0, 2] = 2 * (x * z + y * w)
    m[:, 1, 0] = 2 * (x * y + z * w)
    m[:, 1, 1] = 1 - 2 * (x * x + z * z)
    m[:, 1, 2] = 2 * (y * z - x * w)
    m[:, 2, 0] = 2 * (x * z - y * w)
    m[:, 2, 1] = 2 * (y * z + x * w)
    m[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return m


def matrix_to_quat(m):
    m = np.asarray(m, dtype=float)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        q = [0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s]
    elif m[1, 1] > m[2, 2]:
        s = math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        q = [(m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s]
    else:
        s = math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
        q = [(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s]
    return quat_normalize(q)


def _rotate(q, v):
    """q (floats x, y, z, w) applied to v (3 floats): the rows of quat_to_matrix(q) dotted
    with v, in plain floats."""
    x, y, z, w = q
    vx, vy, vz = v
    return ((1 - 2 * (y * y + z * z)) * vx + 2 * (x * y - z * w) * vy + 2 * (x * z + y * w) * vz,
            2 * (x * y + z * w) * vx + (1 - 2 * (x * x + z * z)) * vy + 2 * (y * z - x * w) * vz,
            2 * (x * z - y * w) * vx + 2 * (y * z + x * w) * vy + (1 - 2 * (x * x + y * y)) * vz)


def quat_rotate(q, v):
    v = np.asarray(v, dtype=float)
    if v.shape != (3,):
        return quat_to_matrix(q).dot(v)
    return np.array(_rotate(_floats(q), v.tolist()))


def _pose(p, q):
    """A Pose from already checked float tuples (no validation)."""
    pose = Pose.__new__(Pose)
    pose.p = np.array(p)
    pose.q = np.array(q)
    return pose


class Pose(object):
    """Position + unit quaternion (x, y, z, w)."""
    __slots__ = ('p', 'q')

    def __init__(self, p=(0.0, 0.0, 0.0), q=(0.0, 0.0, 0.0, 1.0), normalize=True):
        p = np.asarray(p, dtype=float)
        if p.shape != (3,) or not all(map(math.isfinite, p.tolist())):
            raise InvalidPose('position %s is not three finite numbers' % (list(p),))
        self.p = p
        self.q = quat_normalize(q) if normalize else np.asarray(q, dtype=float)

    @classmethod
    def from_xyz_rpy(cls, xyz=(0, 0, 0), rpy=(0, 0, 0)):
        return cls(xyz, quat_from_rpy(*rpy))

    @classmethod
    def from_msg(cls, msg):
        """geometry_msgs/Pose -> Pose; raises InvalidPose on NaN or a zero quaternion."""
        return cls((msg.position.x, msg.position.y, msg.position.z),
                   (msg.orientation.x, msg.orientation.y, msg.orientation.z,
                    msg.orientation.w))

    @classmethod
    def from_matrix(cls, m):
        m = np.asarray(m, dtype=float)
        return cls(m[:3, 3], matrix_to_quat(m[:3, :3]))

    def to_msg(self, msg=None):
        if msg is None:
            from geometry_msgs.msg import Pose as PoseMsg
            msg = PoseMsg()
        msg.position.x, msg.position.y, msg.position.z = (float(v) for v in self.p)
        (msg.orientation.x, msg.orientation.y, msg.orientation.z,
         msg.orientation.w) = (float(v) for v in self.q)
        return msg

    def matrix(self):
        m = np.eye(4)
        m[:3, :3] = quat_to_matrix(self.q)
        m[:3, 3] = self.p
        return m

    def rpy(self):
        return rpy_from_quat(self.q)

    def inverse(self):
        x, y, z, w = self.q.tolist()
        qi = (-x, -y, -z, w)
        r = _rotate(qi, self.p.tolist())
        return _pose((-r[0], -r[1], -r[2]), qi)

    def __mul__(self, other):
        if isinstance(other, Pose):
            q = self.q.tolist()
            px, py, pz = self.p.tolist()
            r = _rotate(q, other.p.tolist())
            return _pose((px + r[0], py + r[1], pz + r[2]),
                         _normalized(*_quat_multiply(q, other.q.tolist())))
        return self.transform_point(other)

    def transform_point(self, v):
        return self.p + quat_rotate(self.q, v)

    def rotate(self, v):
        return quat_rotate(self.q, v)

    def relative_to(self, frame):
        """This pose expressed in ``frame`` (both given in the same parent frame)."""
        return frame.inverse() * self

    def almost_equal(self, other, tol=1e-6):
        dq = min(np.abs(self.q - other.q).max(), np.abs(self.q + other.q).max())
        return np.abs(self.p - other.p).max() <= tol and dq <= tol

    def copy(self):
        return Pose(self.p.copy(), self.q.copy(), normalize=False)

    def __repr__(self):
        return 'Pose(p=%s, q=%s)' % (np.round(self.p, 6).tolist(), np.round(self.q, 6).tolist())
