"""A WiFi coverage map: the received power of one transmitter over a floor (top view), by the
phone's budget (``simsensors.radio_budget``, obstacles by ray casts, no fading), as a
colour PNG with a scale. Used by ``rosrun mobile_device_sim wifi_map`` (simsensors/nodes; ``main`` here).
Import-safe (OpenCV is imported when a picture is written).

  rosrun mobile_device_sim wifi_map [--world office.world] [--bssid 00:1a:2b:3c:4d:01]
      [--z 1.0] [--step 0.05] [--bounds xmin xmax ymin ymax] [--model multiwall|per_metre]
      [--wall-loss 3.4] [--max-incidence 2] [--attenuation 110] [--out wifi_map.png]

Needs no roscore: the world file is loaded as sim_world loads it (access points are
``libgazebo_ros_wifi_ap.so`` plugins). Default: the office world, its first access point,
the floor at 1 m (a phone in the hand), the office with a 1 m margin, the multi-wall model.
"""
import argparse
import logging
import os
import sys

import numpy as np

from . import radio_budget as rb

__all__ = ['power_grid', 'render_map', 'main']


def power_grid(world, tx, xs, ys, z, g_rx=0.0, l_rx=0.0, ignore=(), **wall):
    """(P_RX dBm array [len(ys), len(xs)], solid mask): the budget from ``tx`` to every
    point (x, y, z); ``solid`` marks points inside a collision shape (walls). ``wall``: the
    obstacle model's keyword arguments (``radio_budget.model_loss``; multi-wall by
    default)."""
    seg = world.segment_intervals
    grid = np.zeros((len(ys), len(xs)))
    solid = np.zeros((len(ys), len(xs)), bool)
    a = np.asarray(tx.position(), float)
    ig = tuple(ignore) + ((tx.model,) if tx.model else ())
    for i, y in enumerate(ys):
        for j, x in enumerate(xs):
            p = np.array([x, y, z])
            ivs = seg(p, a, ignore=ig, incidence=True)
            solid[i, j] = bool(ivs) and ivs[0][0] <= 1e-9
            d = float(np.linalg.norm(a - p))
            grid[i, j] = rb.received_power(tx.p_tx, tx.g_tx, tx.l_tx, rb.friis_loss(
                tx.frequency, d), rb.model_loss(ivs, **wall), 0.0, g_rx, l_rx)
    return grid, solid


def render_map(path, grid, solid, xs, ys, lo=-90.0, hi=-20.0, title='', marks=(),
               scale=4):
    """Write the map as a PNG: jet colours from ``lo`` (blue) to ``hi`` (red) dBm, below
    ``lo`` grey, walls black, north (+y) up, a colour bar with dBm labels, ``marks``
    [(x, y, label)] as white dots."""
    import cv2
    t = np.clip((grid - lo) / (hi - lo), 0, 1)
    img = cv2.applyColorMap((t * 255).astype(np.uint8), cv2.COLORMAP_JET)
    img[grid < lo] = (128, 128, 128)
    img[solid] = (0, 0, 0)
    img = img[::-1]                                           # +y up
    img = cv2.resize(img, (img.shape[1] * scale, img.shape[0] * scale),
                     interpolation=cv2.INTER_NEAREST)
    h, w = img.shape[:2]
    dx = xs[1] - xs[0] if len(xs) > 1 else 1.0
    dy = ys[1] - ys[0] if len(ys) > 1 else 1.0
    for x, y, label in marks:
        c = (int((x - xs[0]) / dx * scale + scale / 2),
             int(h - 1 - ((y - ys[0]) / dy * scale + scale / 2)))
        cv2.circle(img, c, 6, (255, 255, 255), -1)
        cv2.circle(img, c, 6, (0, 0, 0), 1)
        cv2.putText(img, label, (c[0] + 8, c[1] - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                    (255, 255, 255), 1, cv2.LINE_AA)
    bar_w, pad = 110, 40
    canvas = np.full((h + 2 * pad, w + bar_w + pad, 3), 255, np.uint8)
    canvas[pad:pad + h, pad // 2:pad // 2 + w] = img
    x0 = pad // 2 + w + 15
    ramp = np.linspace(1, 0, h)[:, None]
    bar = cv2.applyColorMap((np.repeat(ramp, 20, 1) * 255).astype(np.uint8),
                            cv2.COLORMAP_JET)
    canvas[pad:pad + h, x0:x0 + 20] = bar
    for v in np.arange(np.ceil(lo / 10) * 10, hi + 1e-9, 10):
        yy = int(pad + (hi - v) / (hi - lo) * (h - 1))
        cv2.line(canvas, (x0 + 20, yy), (x0 + 26, yy), (0, 0, 0), 1)
        cv2.putText(canvas, '%d dBm' % v, (x0 + 29, yy + 4), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                    (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(canvas, title, (pad // 2, pad - 14), cv2.FONT_HERSHEY_SIMPLEX, 0.5,
                (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(canvas, 'x %.1f..%.1f m, y %.1f..%.1f m (+y up); grey: below %d dBm; '
                'black: walls' % (xs[0], xs[-1], ys[0], ys[-1], lo),
                (pad // 2, pad + h + 25), cv2.FONT_HERSHEY_SIMPLEX, 0.38, (0, 0, 0), 1,
                cv2.LINE_AA)
    if not cv2.imwrite(path, canvas):
        raise IOError('cannot write %s' % path)
    return canvas


def _default_world():
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.environ.get('MDS_ROOT') or os.path.dirname(os.path.dirname(os.path.dirname(here)))
    return os.path.join(root, 'sim_world', 'worlds', 'office.world')


def main(argv=None):
    """``rosrun mobile_device_sim wifi_map``: exit 0 with the PNG written, 2 on bad input
    (one line naming it)."""
    from sim_world.world import World
    ap = argparse.ArgumentParser(prog='wifi_map', description='WiFi received-power map (PNG)')
    ap.add_argument('--world', default=_default_world())
    ap.add_argument('--bssid', default=None, help='access point (default: the first)')
    ap.add_argument('--z', type=float, default=1.0, help='height of the map (m)')
    ap.add_argument('--step', type=float, default=0.05, help='grid step (m)')
    ap.add_argument('--bounds', type=float, nargs=4, default=(-1.0, 7.5, -6.0, 2.0),
                    metavar=('XMIN', 'XMAX', 'YMIN', 'YMAX'))
    ap.add_argument('--model', choices=rb.WALL_MODELS, default='multiwall',
                    help='obstacle loss: multi-wall (COST 231, default) or the thesis per '
                         'metre')
    ap.add_argument('--wall-loss', type=float, default=rb.DEFAULT_WALL_LOSS,
                    help='multiwall: dB per wall of no known material')
    ap.add_argument('--max-incidence', type=float, default=rb.DEFAULT_MAX_INCIDENCE,
                    help='multiwall: bound of the slant-path factor')
    ap.add_argument('--attenuation', type=float, default=rb.DEFAULT_ATTENUATION,
                    help='per_metre: dB/m inside solids')
    ap.add_argument('--out', default='wifi_map.png')
    a = ap.parse_args(rospy_free(argv))
    logging.basicConfig(level=logging.WARNING, format='wifi_map: %(message)s')
    if not (a.step > 0) or a.bounds[1] <= a.bounds[0] or a.bounds[3] <= a.bounds[2]:
        print('wifi_map: --step must be > 0 and the bounds xmin < xmax, ymin < ymax',
              file=sys.stderr)
        return 2
    if not (a.wall_loss >= 0 and a.attenuation >= 0 and a.max_incidence >= 1):
        print('wifi_map: --wall-loss and --attenuation must be >= 0, --max-incidence >= 1',
              file=sys.stderr)
        return 2
    w = World(physics='ode', seed=0)
    try:
        try:
            w.load_world_file(a.world)
        except Exception as e:  # noqa: BLE001 - one line naming the file
            print('wifi_map: cannot load world %s: %s' % (a.world, e), file=sys.stderr)
            return 2
        aps = w.transmitters('wifi')
        if not aps:
            print('wifi_map: world %s has no access point (libgazebo_ros_wifi_ap.so)'
                  % a.world, file=sys.stderr)
            return 2
        tx = aps[0] if a.bssid is None else next(
            (t for t in aps if t.id == a.bssid.lower()), None)
        if tx is None:
            print('wifi_map: no access point with BSSID %s (the world has: %s)'
                  % (a.bssid, ', '.join(t.id for t in aps)), file=sys.stderr)
            return 2
        xs = np.arange(a.bounds[0], a.bounds[1] + 1e-9, a.step)
        ys = np.arange(a.bounds[2], a.bounds[3] + 1e-9, a.step)
        grid, solid = power_grid(w, tx, xs, ys, a.z, wall_model=a.model,
                                 per_wall=a.wall_loss, max_incidence=a.max_incidence,
                                 attenuation=a.attenuation)
        marks = [(t.position()[0], t.position()[1], t.id[-5:]) for t in aps]
        model = ('multi-wall (COST 231)' if a.model == 'multiwall'
                 else 'per metre, %g dB/m' % a.attenuation)
        render_map(a.out, grid, solid, xs, ys, marks=marks,
                   title='WiFi %s (%s, %g MHz) at z = %g m, %s'
                   % (tx.id, tx.name, tx.frequency, a.z, model))
        print('wifi_map: wrote %s (%dx%d points, %.1f .. %.1f dBm)'
              % (a.out, len(xs), len(ys), grid.min(), grid.max()))
        return 0
    finally:
        w.shutdown()


def rospy_free(argv):
    """Drop the __name:= / __log:= arguments roslaunch adds."""
    argv = sys.argv[1:] if argv is None else argv
    return [x for x in argv if ':=' not in x]
