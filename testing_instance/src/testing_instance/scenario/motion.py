"""Pure trajectory and ramp maths of the timeline's actions (no ROS): unit-tested.

Every function returns a list of (dt, value) set points relative to the action's start:
the runner applies each at exactly start + dt of sim time while the world is paused.
"""
import math

import numpy as np

# the quaternion maths is sim_world's (one module), re-exported for the runner
from sim_world.transforms import quat_from_rpy, rpy_from_quat  # noqa: F401
from sim_world.transforms import quat_multiply as quat_mul  # noqa: F401

__all__ = ['quat_from_rpy', 'rpy_from_quat', 'slerp', 'path_points', 'walk_points',
           'rotate_points', 'ramp_points', 'series_points']


def slerp(q0, q1, s):
    q0 = np.asarray(q0, float) / np.linalg.norm(q0)
    q1 = np.asarray(q1, float) / np.linalg.norm(q1)
    d = float(np.dot(q0, q1))
    if d < 0:
        q1, d = -q1, -d
    if d > 0.9995:
        q = q0 + s * (q1 - q0)
        return q / np.linalg.norm(q)
    th = math.acos(d)
    return (math.sin((1 - s) * th) * q0 + math.sin(s * th) * q1) / math.sin(th)


def _times(total, interval):
    n = max(1, int(math.ceil(total / interval - 1e-9)))
    return [min(total, i * interval) for i in range(1, n + 1)]


def _polyline(points):
    pts = np.asarray(points, float)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    return pts, cum


def _at(pts, cum, s):
    """Point and unit direction at arc length s along the polyline."""
    if cum[-1] <= 0:
        return pts[-1], np.zeros(3)
    s = min(max(s, 0.0), cum[-1])
    i = int(np.searchsorted(cum, s, side='right') - 1)
    i = min(i, len(pts) - 2)
    L = cum[i + 1] - cum[i]
    f = (s - cum[i]) / L if L > 0 else 0.0
    d = (pts[i + 1] - pts[i]) / L if L > 0 else np.zeros(3)
    return pts[i] + f * (pts[i + 1] - pts[i]), d


def path_points(start, waypoints, speed, interval=0.02):
    """Constant-speed motion start -> waypoints: [(dt, position, velocity)]; the last set
    point is exactly the last waypoint (velocity zero)."""
    pts, cum = _polyline([start] + [list(w) for w in waypoints])
    total = cum[-1] / speed
    out = []
    for t in _times(total, interval) if total > 0 else [0.0]:
        p, d = _at(pts, cum, t * speed)
        last = t >= total - 1e-12
        out.append((t, p, np.zeros(3) if last else d * speed))
    return out


def walk_points(start, waypoints, speed=1.2, step_frequency=1.8, bounce=0.02, interval=0.02):
    """A hand-held walk: the path of path_points plus a vertical bounce of ``bounce`` m at
    each step (|sin| at step_frequency steps per second), and the walking direction's yaw:
    [(dt, position, velocity, yaw or None)]."""
    out = []
    for t, p, v in path_points(start, waypoints, speed, interval):
        phase = math.pi * step_frequency * t
        last = not np.any(v)
        z = 0.0 if last else bounce * abs(math.sin(phase))
        vz = 0.0 if last else bounce * math.pi * step_frequency * math.cos(phase) * \
            (1 if math.sin(phase) >= 0 else -1)
        yaw = math.atan2(v[1], v[0]) if (v[0] or v[1]) else None
        out.append((t, p + [0, 0, z], v + [0, 0, vz], yaw))
    return out


def rotate_points(q_start, rpy_end, duration, interval=0.02):
    """Turn from q_start to rpy_end over duration s: [(dt, quaternion)]."""
    q1 = quat_from_rpy(*rpy_end)
    if duration <= 0:
        return [(0.0, q1)]
    return [(t, slerp(q_start, q1, t / duration)) for t in _times(duration, interval)]


def ramp_points(start_values, end_values, duration, interval=0.1):
    """Linear ramp of named values: [(dt, {name: value})]; duration 0: one step."""
    if duration <= 0:
        return [(0.0, dict(end_values))]
    out = []
    for t in _times(duration, interval):
        f = t / duration
        out.append((t, {k: start_values.get(k, v) + f * (v - start_values.get(k, v))
                        for k, v in end_values.items()}))
    return out


def series_points(series):
    """A recorded value series [[t, v], ...] (t relative to the action, sorted)."""
    return sorted((float(t), float(v)) for t, v in series)
