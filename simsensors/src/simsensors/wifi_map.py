"""A WiFi coverage map: the received power of one transmitter over a floor (top view), by the
phone's budget (``simsensors.radio_budget``, obstacles by ray casts, no fading), as a
colour PNG with a scale. Used by ``rosrun mobile_device_sim wifi_map`` (simsensors/nodes).
Import-safe (OpenCV is imported when a picture is written)."""
import numpy as np

from . import radio_budget as rb

__all__ = ['power_grid', 'render_map']


def power_grid(world, tx, xs, ys, z, g_rx=0.0, l_rx=0.0, attenuation=rb.DEFAULT_ATTENUATION,
               materials=None, ignore=()):
    """(P_RX dBm array [len(ys), len(xs)], solid mask): the budget from ``tx`` to every
    point (x, y, z); ``solid`` marks points inside a collision shape (walls)."""
    seg = world.segment_intervals
    grid = np.zeros((len(ys), len(xs)))
    solid = np.zeros((len(ys), len(xs)), bool)
    a = np.asarray(tx.position(), float)
    ig = tuple(ignore) + ((tx.model,) if tx.model else ())
    for i, y in enumerate(ys):
        for j, x in enumerate(xs):
            p = np.array([x, y, z])
            ivs = seg(p, a, ignore=ig)
            solid[i, j] = bool(ivs) and ivs[0][0] <= 1e-9
            d = float(np.linalg.norm(a - p))
            grid[i, j] = rb.received_power(tx.p_tx, tx.g_tx, tx.l_tx, rb.friis_loss(
                tx.frequency, d), rb.obstacle_loss(ivs, attenuation, materials), 0.0,
                g_rx, l_rx)
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
