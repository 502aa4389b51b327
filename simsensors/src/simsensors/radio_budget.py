"""The radio link budget of thesis section 3.3.2 (equations 3.3 and 3.4), pure functions.

    P_RX = P_TX + G_TX - L_TX - L_FS - L_OB - L_M + G_RX - L_RX          (dBm, dB, dBi)
    L_FS = -27.55 + 20 log10(f / MHz) + 20 log10(d / m)                   (Friis, 3.4)
    L_OB = the obstacle loss, by one of two wall models (``WALL_MODELS``):
           'multiwall' (default; COST 231 multi-wall, as ITU-R P.1238 practice counts walls):
               sum over the walls crossed of the material's loss per wall (``WALL_LOSS``),
               times min(1 / cos(incidence), max_incidence) for the slant path through the
               wall, times min(1, length inside / wall_thickness) so that a corner clipped
               at its edge or a table leg costs part of a wall, not a whole one;
           'per_metre' (the thesis): sum over the solids crossed of length x attenuation
               (dB/m; 110 dB/m for 2.4 GHz through solid walls, the thesis's clue). A ray
               that skims along a wall travels metres inside it: losses without bound.
    L_M  = 0 | log-normal shadowing N(0, sigma) dB | Rayleigh fading -10 log10(|h|^2),
           |h|^2 ~ Exp(1)   (drawn from the caller's seeded generator)

Losses are magnitudes in dB: the thesis quotes L_TX and L_RX as "-3 to -10 dB"; a negative
figure is read as its magnitude (a loss never adds power). Distances below ``MIN_DISTANCE``
are taken as ``MIN_DISTANCE`` (the far-field formula has no meaning at the antenna).

No ROS and no World here: ``Transmitter`` (an access point, a cell tower, a Bluetooth device
registered in ``world.environment.transmitters``) holds its figures and a callable giving its
world position; ``budget_to`` evaluates the chain for one receiver position.
"""
import math
import re

import numpy as np

__all__ = ['friis_loss', 'obstacle_loss', 'misc_loss', 'received_power', 'link_speed',
           'RATE_TABLE', 'asu_from_dbm', 'wifi_frequency', 'wifi_channel', 'valid_bssid',
           'parse_materials', 'Transmitter', 'budget_to', 'MIN_DISTANCE', 'FADING',
           'WALL_MODELS', 'WALL_LOSS', 'DEFAULT_WALL_LOSS', 'wall_loss', 'parse_wall_losses',
           'DEFAULT_MAX_INCIDENCE', 'DEFAULT_WALL_THICKNESS', 'model_loss']

MIN_DISTANCE = 0.1          # m
DEFAULT_ATTENUATION = 110.0  # dB/m (thesis: 2.4 GHz WLAN through solid walls [43])
FADING = ('none', 'lognormal', 'rayleigh')
WALL_MODELS = ('multiwall', 'per_metre')

#: Loss per wall crossed head-on (dB, 1-6 GHz WLAN/cellular), by the collision <material>
#: name. Sources: COST 231 final report (1999), section 4.6.1, multi-wall model fitted at
#: 1.8 GHz: light (plasterboard, wood) walls 3.4 dB, heavy (brick, concrete) walls 6.9 dB;
#: ITU-R P.1238-12 and P.2040-3 (building-material penetration, 1-10 GHz): glass 2-3 dB,
#: wood 3-5 dB, brick 6-10 dB, concrete 10-20 dB depending on thickness; metal: effectively
#: opaque (a large finite value keeps the budget finite). These are typical figures, not a
#: measurement of any one building: tune them per world with ``materialWallLoss``.
WALL_LOSS = {
    'plasterboard': 3.4, 'drywall': 3.4, 'light_wall': 3.4,
    'wood': 4.0, 'door': 4.0,
    'glass': 2.5, 'window': 2.5,
    'brick': 6.9, 'heavy_wall': 6.9,
    'concrete': 12.0, 'reinforced_concrete': 18.0,
    'metal': 30.0,
}
DEFAULT_WALL_LOSS = 3.4        # dB, a solid of no known material: COST 231's light wall
DEFAULT_MAX_INCIDENCE = 2.0    # slant-path factor bound (a grazing ray costs <= 2 walls)
DEFAULT_WALL_THICKNESS = 0.1   # m, nominal: crossings shorter than this cost a fraction

#: 802.11a/g OFDM rates against the minimum received power (IEEE 802.11-2007 17.3.10.1
#: receiver sensitivities + typical implementation margins: 54 Mbit/s at -65 dBm ... 6 at
#: -82 dBm); between -82 dBm and the receiver sensitivity the link falls back to the
#: 802.11b DSSS basic rate 1 Mbit/s
RATE_TABLE = ((-65.0, 54), (-66.0, 48), (-70.0, 36), (-74.0, 24), (-77.0, 18), (-79.0, 12),
              (-81.0, 9), (-82.0, 6))

_BSSID = re.compile(r'^[0-9a-fA-F]{2}(:[0-9a-fA-F]{2}){5}$')


def friis_loss(frequency_mhz, distance_m):
    """Free-space loss L_FS (dB), equation 3.4."""
    d = max(float(distance_m), MIN_DISTANCE)
    return -27.55 + 20.0 * math.log10(float(frequency_mhz)) + 20.0 * math.log10(d)


def obstacle_loss(intervals, attenuation=DEFAULT_ATTENUATION, materials=None):
    """L_OB (dB): ``intervals`` as from ``world.segment_intervals`` ((enter, exit, model,
    link, material) ...) or plain (enter, exit) pairs; ``materials`` maps a material name to
    its attenuation (dB/m); other parts take ``attenuation``."""
    materials = materials or {}
    total = 0.0
    for iv in intervals:
        length = float(iv[1]) - float(iv[0])
        mat = iv[4] if len(iv) > 4 else None
        total += length * materials.get(mat, attenuation)
    return total


def wall_loss(intervals, per_wall=DEFAULT_WALL_LOSS, materials=None,
              max_incidence=DEFAULT_MAX_INCIDENCE, thickness=DEFAULT_WALL_THICKNESS):
    """L_OB (dB) by the multi-wall model: ``intervals`` as from
    ``world.segment_intervals(..., incidence=True)`` ((enter, exit, model, link, material,
    shape thickness) ...; without a thickness, or with None, ``thickness`` is taken). Each
    crossing costs ``materials.get(material, WALL_LOSS.get(material, per_wall))`` times
    min(length / shape thickness, max_incidence): 1 for a head-on crossing of a slab,
    1/cos(incidence) at a slant (the slant path through the wall), bounded by
    ``max_incidence`` for grazing rays, and a fraction where a corner or a thin leg is
    clipped. The loss is continuous in the receiver's position (no grazing stripes)."""
    materials = materials or {}
    mx = max(1.0, float(max_incidence))
    total = 0.0
    for iv in intervals:
        mat = iv[4] if len(iv) > 4 else None
        loss = materials[mat] if mat in materials else WALL_LOSS.get(mat, per_wall)
        th = iv[5] if len(iv) > 5 and iv[5] else float(thickness)
        length = float(iv[1]) - float(iv[0])
        total += loss * (min(length / th, mx) if th > 0 else mx)
    return total


def misc_loss(rng, fading='none', sigma=0.0):
    """One draw of L_M (dB) from ``rng`` (numpy Generator). Always draws exactly once for
    'lognormal' and 'rayleigh' (so a fixed seed gives a fixed sequence)."""
    if fading == 'none':
        return 0.0
    if fading == 'lognormal':
        return float(rng.normal(0.0, sigma))
    if fading == 'rayleigh':
        power = float(rng.exponential(1.0))       # |h|^2 of a unit-mean Rayleigh channel
        return -10.0 * math.log10(max(power, 1e-12))
    raise ValueError('fading must be one of %s, got %r' % (', '.join(FADING), fading))


def received_power(p_tx, g_tx, l_tx, l_fs, l_ob, l_m, g_rx, l_rx):
    """Equation 3.3 (dBm)."""
    return p_tx + g_tx - abs(l_tx) - l_fs - l_ob - l_m + g_rx - abs(l_rx)


def link_speed(p_rx, sensitivity=-90.0, table=RATE_TABLE):
    """Mbit/s the received power supports: 0 below the sensitivity (disconnected)."""
    if p_rx is None or p_rx < sensitivity:
        return 0
    for threshold, rate in table:
        if p_rx >= threshold:
            return rate
    return 1


def asu_from_dbm(dbm):
    """3GPP TS 27.007 (+CSQ) ASU for GSM: dBm = -113 + 2 ASU, 0..31; 99 unknown (None)."""
    if dbm is None or not math.isfinite(dbm):
        return 99
    return int(min(31, max(0, math.floor((dbm + 113.0) / 2.0))))


def wifi_frequency(channel):
    """Centre frequency (MHz) of a 2.4 GHz (1..14) or 5 GHz (32..177) WiFi channel."""
    channel = int(channel)
    if 1 <= channel <= 13:
        return 2407 + 5 * channel
    if channel == 14:
        return 2484
    if 32 <= channel <= 177:
        return 5000 + 5 * channel
    raise ValueError('WiFi channel must be 1..14 or 32..177, got %d' % channel)


def wifi_channel(frequency):
    f = int(round(frequency))
    if f == 2484:
        return 14
    if 2412 <= f <= 2472:
        return (f - 2407) // 5
    if 5160 <= f <= 5885:
        return (f - 5000) // 5
    return 0


def valid_bssid(text):
    return bool(_BSSID.match(str(text or '').strip()))


def parse_materials(text):
    """'drywall:110 glass:30' -> {'drywall': 110.0, 'glass': 30.0}; raises ValueError."""
    out = {}
    for item in str(text or '').replace(',', ' ').split():
        name, sep, val = item.partition(':')
        if not sep or not name:
            raise ValueError('%r is not name:dB_per_metre' % item)
        v = float(val)
        if not (math.isfinite(v) and v >= 0):
            raise ValueError('%r: attenuation must be >= 0 dB/m' % item)
        out[name] = v
    return out


parse_materials.what = 'name:dB_per_metre pairs (e.g. "glass:30 wood:40")'


def parse_wall_losses(text):
    """'drywall:3 glass:2' -> {'drywall': 3.0, 'glass': 2.0} (dB per wall); raises
    ValueError."""
    try:
        return parse_materials(text)
    except ValueError as e:
        raise ValueError(str(e).replace('name:dB_per_metre', 'name:dB_per_wall')
                         .replace('dB/m', 'dB'))


parse_wall_losses.what = 'name:dB_per_wall pairs (e.g. "drywall:3.4 concrete:12")'


class Transmitter(object):
    """A radio source in the world: kind ('wifi', 'cell', 'bluetooth'), id (BSSID / cell
    id / device name), name (SSID / operator / device name), frequency (MHz), channel,
    p_tx (dBm), g_tx (dBi), l_tx (dB), ``position()`` -> world point, ``model`` (ignored
    by the obstacle ray cast), ``owner`` (the plugin), ``extra`` (dict)."""

    def __init__(self, kind, id, name, frequency, p_tx, g_tx, l_tx, position, model='',
                 channel=0, owner=None, **extra):
        self.kind, self.id, self.name = kind, id, name
        self.frequency, self.channel = float(frequency), int(channel)
        self.p_tx, self.g_tx, self.l_tx = float(p_tx), float(g_tx), float(l_tx)
        self.position = position
        self.model = model
        self.owner = owner
        self.extra = extra

    def __repr__(self):
        return '<Transmitter %s %s %r %g MHz>' % (self.kind, self.id, self.name,
                                                  self.frequency)


def model_loss(intervals, wall_model='multiwall', per_wall=DEFAULT_WALL_LOSS,
               wall_materials=None, max_incidence=DEFAULT_MAX_INCIDENCE,
               thickness=DEFAULT_WALL_THICKNESS, attenuation=DEFAULT_ATTENUATION,
               materials=None):
    """L_OB (dB) of ``intervals`` (from ``segment_intervals(..., incidence=True)``) by
    ``wall_model``: 'multiwall' (``wall_loss``) or 'per_metre' (``obstacle_loss``)."""
    if wall_model == 'multiwall':
        return wall_loss(intervals, per_wall, wall_materials, max_incidence, thickness)
    if wall_model == 'per_metre':
        return obstacle_loss(intervals, attenuation, materials)
    raise ValueError('wall model must be one of %s, got %r' % (', '.join(WALL_MODELS),
                                                               wall_model))


def budget_to(tx, rx_pos, g_rx=0.0, l_rx=0.0, segment_intervals=None, ignore=(), l_m=0.0,
              **wall):
    """(P_RX dBm, dict of the terms) from transmitter ``tx`` to the point ``rx_pos``.
    ``segment_intervals(a, b, ignore, incidence)`` (world.segment_intervals) gives the
    obstacles; the transmitter's own model is always ignored. ``wall``: the keyword
    arguments of ``model_loss`` (wall_model='multiwall' by default)."""
    a = np.asarray(tx.position(), float)
    b = np.asarray(rx_pos, float)
    d = float(np.linalg.norm(b - a))
    l_fs = friis_loss(tx.frequency, d)
    l_ob = 0.0
    if segment_intervals is not None and d > 0:
        ig = tuple(ignore) + ((tx.model,) if tx.model else ())
        l_ob = model_loss(segment_intervals(b, a, ignore=ig, incidence=True), **wall)
    p = received_power(tx.p_tx, tx.g_tx, tx.l_tx, l_fs, l_ob, l_m, g_rx, l_rx)
    return p, dict(distance=d, l_fs=l_fs, l_ob=l_ob, l_m=l_m)
