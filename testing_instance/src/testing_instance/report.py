"""Scenario reports a person opens in a browser (run_scenario ... --report DIR).

``Collector`` rides along a run (live or --replay): the runner subscribes the topics it
wants (``image_topics``: cameras, display, flycam), hands it every message it feeds the
expectations (``feed``) and its log folder before it is removed (``grab_logs``); the events
come from the runner's ``event_times`` (live: as they fired; replay: as recorded). ``Collector.write(result)`` then writes

    DIR/index.html     the report: header (scenario, seed, world, real-time factor, wall and
                       sim time, exit status, the command that reruns it), the verdict table
                       (each row links to its plot), the timeline of events and verdicts on
                       the sim-time axis, per numeric expectation a static SVG plot of the
                       field over sim time with the window shaded, the predicate's band or
                       threshold drawn and the deciding message marked, the camera, display
                       and spectator (flycam) frames at every event and verdict with the
                       checked region or barcode outlined, and on ERROR the log tails
    DIR/report.json    the same facts as data (verdicts, plotted points, events, frames)
    DIR/img/*.jpg      the frames

Everything is in DIR: no script, font or style is fetched from anywhere (static SVG, inline
CSS, no JavaScript). ``write_index(DIR, runs)`` writes a farm's index page.

Bad input never changes a run's verdicts or exit code: a report folder that cannot be
written is one line (``report: cannot write ...``), a field that is not numeric gets no plot
and its row says so.
"""
import html
import json
import math
import os
import re
import shlex
import time

from .scenario.expect import FieldError, get_field, to_value

__all__ = ['Collector', 'write_index', 'write_invalid', 'svg_plot', 'numeric_value', 'nice_ticks',
           'report_image_topics']

PLOT_W, PLOT_H = 720, 230
ML, MR, MT, MB = 64, 16, 14, 34          # plot margins (px)
MAX_POINTS = 1500                        # per series: min/max decimation above this
FRAME_SPACING = 0.05                     # s of sim time between kept frames of a topic
MAX_FRAMES = 240                         # per topic; above it every other frame is dropped
FRAME_MAX_W = 360                        # px: frames are kept at most this wide
MAX_MARKS = 40                           # moments (events, verdicts) with frames shown
LOG_TAIL = 40
SHOW_W = 260                             # px: the longer side of a frame on the page
STATUS_COLOURS = {'PASS': '#1a7f37', 'FAIL': '#cf222e', 'ERROR': '#9a6700'}


def numeric_value(v):
    """A plottable value: a float, a list of floats (vectors), or None (not numeric)."""
    v = to_value(v)
    if isinstance(v, bool):
        return float(v)
    if isinstance(v, (int, float)):
        return float(v)
    if isinstance(v, list) and 0 < len(v) <= 4 and all(
            isinstance(x, (int, float)) and not isinstance(x, str) for x in v):
        return [float(x) for x in v]
    return None


def nice_ticks(lo, hi, n=5):
    """About n round tick values covering [lo, hi]."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return [lo]
    raw = (hi - lo) / max(1, n)
    mag = 10 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 2.5, 5, 10) if m * mag >= raw)
    first = math.ceil(lo / step - 1e-9) * step
    out = []
    k = 0
    while first + k * step <= hi + step * 1e-9 and k < 50:
        out.append(round(first + k * step, 12))
        k += 1
    return out


def _fmt_num(v):
    if v == 0:
        return '0'
    if abs(v) >= 1e5 or abs(v) < 1e-3:
        return '%.3g' % v
    return ('%.4f' % v).rstrip('0').rstrip('.')


def _esc(s):
    return html.escape(str(s), quote=True)


def slug(text):
    return ''.join(c if c.isalnum() or c in '-_' else '_' for c in str(text)).strip('_') or 'x'


def decimate(points, max_points=MAX_POINTS):
    """At most ~max_points of [(t, v)]: per bucket of time its first, min, max and last
    (keeps spikes; deterministic)."""
    if len(points) <= max_points:
        return list(points)
    n_b = max_points // 4
    t0, t1 = points[0][0], points[-1][0]
    span = (t1 - t0) or 1.0
    buckets = {}
    for p in points:
        b = min(n_b - 1, int((p[0] - t0) / span * n_b))
        buckets.setdefault(b, []).append(p)
    out = []
    for b in sorted(buckets):
        ps = buckets[b]
        keep = {0, len(ps) - 1, min(range(len(ps)), key=lambda i: ps[i][1]),
                max(range(len(ps)), key=lambda i: ps[i][1])}
        out += [ps[i] for i in sorted(keep)]
    return out


def band_of(spec):
    """What to draw for a predicate: (kind, lo, hi) with kind 'band' (lo..hi is good),
    'above' (>= lo good), 'below' (<= hi good), 'outside' (not_equals: lo..hi is bad), or
    None. Numbers only."""
    def num(x):
        return isinstance(x, (int, float)) and not isinstance(x, bool)
    tol = float(spec.get('tol', 0.0) or 0.0)
    if 'near' in spec and num(spec['near']):
        return ('band', spec['near'] - tol, spec['near'] + tol)
    if 'equals' in spec and num(spec['equals']):
        return ('band', spec['equals'] - tol, spec['equals'] + tol)
    if 'between' in spec:
        lo, hi = spec['between']
        return ('band', float(lo), float(hi))
    lo = next((float(spec[k]) for k in ('gt', 'ge', 'min') if k in spec and num(spec[k])), None)
    hi = next((float(spec[k]) for k in ('lt', 'le', 'max') if k in spec and num(spec[k])), None)
    if lo is not None and hi is not None:
        return ('band', lo, hi)
    if lo is not None:
        return ('above', lo, None)
    if hi is not None:
        return ('below', None, hi)
    if 'not_equals' in spec and num(spec['not_equals']):
        return ('outside', spec['not_equals'] - tol, spec['not_equals'] + tol)
    return None


def svg_plot(series, t_range, window=None, band=None, decider=None, status='PASS',
             ylabel='', events=()):
    """A static SVG plot. series: [(label, [(t, v)])]; t_range (t0, t1); window (a, b) shaded;
    band from band_of; decider (t, v or None) marked; events [(t, label)] as ticks."""
    x0, x1 = t_range
    if x1 <= x0:
        x1 = x0 + 1.0
    vals = [v for _l, pts in series for _t, v in pts]
    if band:
        vals += [b for b in band[1:] if b is not None]
    if decider and decider[1] is not None:
        vals.append(decider[1])
    lo, hi = (min(vals), max(vals)) if vals else (0.0, 1.0)
    if hi - lo < 1e-9:
        lo, hi = lo - 1.0, hi + 1.0
    pad = (hi - lo) * 0.08
    lo, hi = lo - pad, hi + pad
    iw, ih = PLOT_W - ML - MR, PLOT_H - MT - MB

    def X(t):
        return ML + (t - x0) / (x1 - x0) * iw

    def Y(v):
        return MT + (hi - v) / (hi - lo) * ih
    o = ['<svg class="plot-svg" xmlns="http://www.w3.org/2000/svg" viewBox="0 0 %d %d" '
         'width="%d" height="%d" role="img">' % (PLOT_W, PLOT_H, PLOT_W, PLOT_H)]
    o.append('<rect class="plot-bg" x="%d" y="%d" width="%d" height="%d" fill="#ffffff" '
             'stroke="#8c959f"/>' % (ML, MT, iw, ih))
    if window:
        a, b = max(window[0], x0), min(window[1], x1)
        o.append('<rect class="window" x="%.1f" y="%d" width="%.1f" height="%d" '
                 'fill="#ddf4ff"><title>window [%.3f, %.3f] s</title></rect>'
                 % (X(a), MT, max(1.0, X(b) - X(a)), ih, window[0], window[1]))
    if band:
        kind, blo, bhi = band
        top = Y(min(hi, bhi)) if bhi is not None else MT
        bot = Y(max(lo, blo)) if blo is not None else MT + ih
        colour = '#cf222e' if kind == 'outside' else '#2da44e'
        o.append('<rect class="band" x="%d" y="%.1f" width="%d" height="%.1f" fill="%s" '
                 'fill-opacity="0.22"><title>%s</title></rect>'
                 % (ML, top, iw, max(1.0, bot - top), colour, _esc(
                     'expected %s' % ({'band': 'in [%s, %s]', 'outside': 'not in [%s, %s]'}
                                      .get(kind, '%s .. %s') % (
                         _fmt_num(blo) if blo is not None else '-inf',
                         _fmt_num(bhi) if bhi is not None else 'inf')))))
        for b in (blo, bhi):
            if b is not None and lo <= b <= hi:
                o.append('<line class="threshold" x1="%d" x2="%d" y1="%.1f" y2="%.1f" '
                         'stroke="#1a7f37" stroke-width="1.5" stroke-dasharray="6 3"/>'
                         % (ML, ML + iw, Y(b), Y(b)))
    # axes and ticks
    for tv in nice_ticks(lo, hi):
        if lo <= tv <= hi:
            o.append('<line x1="%d" x2="%d" y1="%.1f" y2="%.1f" stroke="#eaeef2"/>'
                     '<text x="%d" y="%.1f" font-size="11" text-anchor="end" fill="#57606a">'
                     '%s</text>' % (ML, ML + iw, Y(tv), Y(tv), ML - 4, Y(tv) + 4,
                                    _fmt_num(tv)))
    for tt in nice_ticks(x0, x1, 8):
        o.append('<line x1="%.1f" x2="%.1f" y1="%d" y2="%d" stroke="#8c959f"/>'
                 '<text x="%.1f" y="%d" font-size="11" text-anchor="middle" fill="#57606a">'
                 '%s</text>' % (X(tt), X(tt), MT + ih, MT + ih + 4, X(tt), MT + ih + 16,
                                _fmt_num(tt)))
    o.append('<text x="%d" y="%d" font-size="11" text-anchor="end" fill="#57606a">sim time '
             '(s)</text>' % (ML + iw, PLOT_H - 3))
    if ylabel:
        o.append('<text x="12" y="%d" font-size="11" fill="#57606a" transform="rotate(-90 12 %d)"'
                 ' text-anchor="middle">%s</text>' % (MT + ih // 2, MT + ih // 2, _esc(ylabel)))
    for te, label in events:
        if x0 <= te <= x1:
            o.append('<line class="event-tick" x1="%.1f" x2="%.1f" y1="%d" y2="%d" '
                     'stroke="#8250df" stroke-width="1" stroke-dasharray="2 3"><title>%s</title>'
                     '</line>' % (X(te), X(te), MT, MT + ih, _esc(label)))
    colours = ['#0969da', '#bf3989', '#1b7c83', '#953800']
    for i, (label, pts) in enumerate(series):
        if not pts:
            continue
        c = colours[i % len(colours)]
        path = ' '.join('%.1f,%.1f' % (X(t), Y(v)) for t, v in pts)
        o.append('<polyline class="series" fill="none" stroke="%s" stroke-width="1.6" '
                 'points="%s"><title>%s</title></polyline>' % (c, path, _esc(label)))
        if len(pts) <= 120:            # hover: a point's time and value
            o.append(''.join('<circle class="pt" cx="%.1f" cy="%.1f" r="2.5" fill="%s">'
                             '<title>t=%.3f s: %s</title></circle>'
                             % (X(t), Y(v), c, t, _fmt_num(v)) for t, v in pts))
    if decider is not None and decider[0] is not None:
        td, vd = decider
        c = STATUS_COLOURS.get(status, '#24292f')
        o.append('<g class="decider">')
        o.append('<line class="decide-line" x1="%.1f" x2="%.1f" y1="%d" y2="%d" stroke="%s" '
                 'stroke-width="2"/>' % (X(td), X(td), MT, MT + ih, c))
        if vd is not None:
            o.append('<circle class="decide-point" cx="%.1f" cy="%.1f" r="6" fill="none" '
                     'stroke="%s" stroke-width="2.5"/>' % (X(td), Y(vd), c))
        label = 't=%.3f s' % td + (': %s' % _fmt_num(vd) if vd is not None else '')
        anchor = 'end' if X(td) > ML + iw * 0.7 else 'start'
        dx = -6 if anchor == 'end' else 6
        o.append('<text class="decide-label" x="%.1f" y="%d" font-size="12" font-weight="bold" '
                 'fill="%s" text-anchor="%s">%s %s</text>' % (X(td) + dx, MT + 14, c, anchor,
                                                              status, _esc(label)))
        o.append('</g>')
    o.append('</svg>')
    return ''.join(o)


def report_image_topics(runner):
    """The image topics a report shows: each phone's camera, the display's topic, the
    flycam and every image expectation's topic -> {topic: role}."""
    sc = runner.sc
    out = {}
    disp = (sc.world.get('args') or {}).get('display_topic')
    for i, ph in enumerate(sc.phones):
        out['/%s/image_raw' % ph['ns'].strip('/')] = 'camera (%s%s)' % (
            ph['ns'], '; its display shows it' if i == 0 and not disp else '')
    if disp:
        out.setdefault(disp, 'display (%s)' % sc.phones[0]['ns'])
    out['/flycam/image_raw'] = 'spectator (flycam)'
    for e in runner.expectations:
        if e.pred.is_image:
            out.setdefault(e.topic, 'image (%s)' % e.topic)
    return out


class _Frames(object):
    """A thinned history of one image topic: at most MAX_FRAMES small RGB copies, at least
    ``spacing`` s of sim time apart (the spacing doubles when full)."""

    def __init__(self):
        self.items = []          # (t, array, (orig_w, orig_h))
        self.spacing = FRAME_SPACING
        self.slot = None         # sim time where the last item's slot began

    def add(self, t, msg):
        """Each slot of ``spacing`` s keeps its latest frame (a display that changes right
        after a frame still shows what it changed to)."""
        from simvid.imageconv import image_to_rgb
        rgb = image_to_rgb(msg)
        h, w = rgb.shape[:2]
        k = max(1, int(math.ceil(w / float(FRAME_MAX_W))))
        small = rgb[::k, ::k].copy()
        if self.items and t - self.slot < self.spacing - 1e-9:
            self.items[-1] = (t, small, (w, h))
            return
        self.slot = t
        self.items.append((t, small, (w, h)))
        if len(self.items) > MAX_FRAMES:
            self.items = self.items[1::2]
            self.spacing *= 2

    def at(self, t):
        """The frame shown at t: the last one at or before t, else the first one."""
        best = None
        for it in self.items:
            if it[0] <= t + 1e-6:
                best = it
            else:
                break
        if best is None and self.items:
            best = self.items[0]
        return best


class Collector(object):
    """Gathers what a report shows while the runner runs (see the module doc)."""

    def __init__(self, runner, out_dir, mode='live'):
        self.r = runner
        self.dir = out_dir
        self.mode = mode
        self.wall0 = time.monotonic()
        self.cost = 0.0                       # wall s spent here (the bench's figure)
        self.exps = list(runner.expectations)
        self.by_topic = {}
        for e in self.exps:
            self.by_topic.setdefault(e.topic, []).append(e)
        self.series = {e.name: [] for e in self.exps}      # numeric: (t, float | [floats])
        self.values = {e.name: [] for e in self.exps}      # non-numeric: changes (t, text)
        self.not_numeric = {}                               # name -> what the value was
        self.msg_times = {e.name: [] for e in self.exps}   # count/rate
        self.deciding = {}                                  # name -> (t, msg) image decider
        self.last_in_window = {}
        self.frames = {}
        self.image_topics = report_image_topics(runner)
        self.logs = {}
        self.problems = {}                                  # topic -> what went wrong

    # -- hooks the runner calls --------------------------------------------------------------
    def feed(self, t, topic, msg):
        """One message as the expectations saw it; never raises (the run goes on: what
        could not be collected is named in one line when the report is written)."""
        c0 = time.monotonic()
        try:
            self._feed(t, topic, msg)
        except Exception as e:  # noqa: BLE001 - a report never changes a run
            self.problems.setdefault(topic, '%s: %s' % (type(e).__name__, e))
        finally:
            self.cost += time.monotonic() - c0

    def _feed(self, t, topic, msg):
        if topic in self.image_topics and getattr(msg, '_type', '') == 'sensor_msgs/Image':
            try:
                self.frames.setdefault(topic, _Frames()).add(t, msg)
            except Exception:  # noqa: BLE001 - an encoding the report cannot show
                self.image_topics.pop(topic, None)
        for e in self.by_topic.get(topic, ()):
            if e.mode in ('count', 'rate'):
                self.msg_times[e.name].append(t)
                continue
            if e.pred.is_image:
                w = e.window
                if w is not None and w[0] - 1e-9 <= t <= w[1] + 1e-9 and \
                        e.name not in self.deciding:
                    self.last_in_window[e.name] = (t, msg)
                    if e.verdict is not None and e.verdict.t is not None and \
                            abs(e.verdict.t - t) < 1e-9:
                        self.deciding[e.name] = (t, msg)
                continue
            try:
                raw = get_field(msg, e.field)
            except FieldError:
                continue
            if e.name in self.not_numeric:
                self._value_change(e, t, raw)
                continue
            v = numeric_value(raw)
            if v is None:
                self.not_numeric[e.name] = '%s %s' % (type(to_value(raw)).__name__,
                                                      _short(repr(to_value(raw))))
                self.series[e.name] = []
                self._value_change(e, t, raw)
                continue
            self.series[e.name].append((t, v))

    def _value_change(self, e, t, raw):
        """Non-numeric values: their changes over sim time (at most 50) instead of a plot."""
        text = _short(repr(to_value(raw)))
        vals = self.values[e.name]
        if (not vals or vals[-1][1] != text) and len(vals) < 50:
            vals.append((t, text))

    def grab_logs(self, run_dir):
        """Tails of the world's and the apps' logs (the run folder is about to go)."""
        try:
            names = sorted(f for f in os.listdir(run_dir) if f.endswith('.log'))
        except OSError:
            return
        for f in names:
            try:
                with open(os.path.join(run_dir, f), errors='replace') as fh:
                    self.logs[f] = [_ANSI.sub('', ln.rstrip('\n'))
                                    for ln in fh.readlines()[-LOG_TAIL:]]
            except OSError:
                pass

    # -- the report ------------------------------------------------------------------------
    def write(self, result, out=None):
        """Write the report; never raises (one line through ``out`` instead)."""
        out = out or self.r.say
        c0 = time.monotonic()
        try:
            path = self._write(result, out)
        except OSError as e:
            out('report: cannot write the report to %s: %s' % (self.dir, e.strerror or e))
            return None
        except Exception as e:  # noqa: BLE001 - a report never changes a run's outcome
            out('report: could not make the report in %s: %s: %s' % (self.dir,
                                                                     type(e).__name__, e))
            return None
        finally:
            self.cost += time.monotonic() - c0
        for topic, what in sorted(self.problems.items()):
            out('report: messages of %s could not be collected (%s)' % (topic, what))
        out('report: %s (%.2f s to make)' % (path, self.cost))
        return path

    def _timeline_events(self):
        """[(t, id, action, text, trigger)] of the events that fired (live or recorded)."""
        by_id = {ev['id']: ev for ev in self.r.sc.timeline}
        out = []
        for eid, t in sorted(self.r.event_times.items(), key=lambda kv: (kv[1], kv[0])):
            ev = by_id.get(eid, {})
            trig = 'at' if 'at' in ev else ('when' if 'when' in ev else
                                            ('after %s' % ev['after'] if 'after' in ev else ''))
            out.append((t, eid, ev.get('action', '?'), ev.get('text', ''), trig))
        return out

    def data(self, result):
        """The report's facts (report.json); plotted points rounded to 1e-6."""
        r = self.r
        t0 = float(getattr(r, 't0', 0.0) or 0.0)
        lw = getattr(r, 'loop_wall', None)
        d = dict(scenario=r.sc.name, path=os.path.abspath(r.sc.path), mode=self.mode,
                 description=getattr(r.sc, 'description', '') or '',
                 seed=r.seed, real_time_factor=r.rtf,
                 achieved_rtf=(lw[1] / lw[0]) if lw and lw[0] > 0 else None,
                 world=dict(r.sc.world), status=result.status, exit_code=result.exit_code,
                 wall=round(result.wall, 3), sim_time=round(result.sim_time - t0, 6),
                 t0=t0, duration=r.sc.duration, error=result.error,
                 replay=os.path.abspath(r.replay) if r.replay else None,
                 command=self.command(), verdicts=[], events=[], plots={}, frames=[])
        for t, eid, action, text, trig in self._timeline_events():
            d['events'].append(dict(t=round(t, 6), id=eid, action=action, text=text,
                                    trigger=trig))
        by_name = {e.name: e for e in self.exps}
        for v in result.verdicts:
            e = by_name.get(v.name)
            row = dict(name=v.name, status=v.status, expected=v.expected, actual=v.actual,
                       t=None if v.t is None else round(v.t, 6), plot=None, note='')
            if e is not None:
                p = self._plot_data(e, v)
                if p is not None:
                    d['plots'][v.name] = p
                    row['plot'] = 'plot-' + slug(v.name)
                row['note'] = self._note(e)
            d['verdicts'].append(row)
        return d

    def _note(self, e):
        if e.pred.is_image:
            return 'image: frame below'
        if e.name in self.not_numeric:
            return 'no plot: %s.%s is not numeric (%s)' % (e.topic, e.field, self.not_numeric[
                e.name])
        if e.mode not in ('count', 'rate') and not e.field:
            return 'no plot: no field'
        if e.mode not in ('count', 'rate') and not self.series.get(e.name):
            return 'no plot: no message'
        if e.mode == 'count' and not self.msg_times.get(e.name):
            return 'no plot: no message'
        if e.mode == 'rate' and len(self.msg_times.get(e.name, ())) < 2:
            return 'no plot: fewer than two messages'
        return ''

    def _plot_data(self, e, v):
        spec = e.pred.spec
        w = e.window
        if e.mode == 'rate':
            ts = self.msg_times[e.name]
            pts = [(b, 1.0 / (b - a)) for a, b in zip(ts, ts[1:]) if b > a]
            series = [('messages per second (1/interval)', pts)]
            ylabel = 'Hz'
            dv = None
            if w is not None:
                inw = [t for t in ts if w[0] - 1e-9 <= t <= w[1] + 1e-9]
                if len(inw) >= 2 and inw[-1] > inw[0]:
                    dv = (len(inw) - 1) / (inw[-1] - inw[0])
        elif e.mode == 'count':
            ts = [t for t in self.msg_times[e.name]
                  if w is None or w[0] - 1e-9 <= t <= w[1] + 1e-9]
            series = [('messages in the window (cumulative)',
                       [(t, float(i + 1)) for i, t in enumerate(ts)])]
            ylabel = 'messages'
            dv = float(len(ts))
        else:
            if e.pred.is_image or e.name in self.not_numeric or not self.series.get(e.name):
                return None
            raw = self.series[e.name]
            if isinstance(raw[0][1], list):
                n = len(raw[0][1])
                comp = 'xyzw'
                series = [('%s.%s' % (e.field, comp[i] if n <= 4 else i),
                           [(t, vv[i]) for t, vv in raw if isinstance(vv, list) and len(vv) == n])
                          for i in range(n)]
            else:
                series = [(e.field, raw)]
            ylabel = e.field
            dv = None
            if v.t is not None:
                at = [vv for t, vv in raw if abs(t - v.t) < 1e-9]
                if at and not isinstance(at[-1], list):
                    dv = at[-1]
        series = [(label, [(round(t, 6), round(val, 6)) for t, val in decimate(pts)])
                  for label, pts in series]
        if not any(pts for _l, pts in series):
            return None                   # nothing to draw: the row says why
        band = band_of(spec) if len(series) == 1 else None
        return dict(series=series, window=[round(x, 6) for x in w] if w else None,
                    band=list(band) if band else None, ylabel=ylabel,
                    decider=[None if v.t is None else round(v.t, 6),
                             None if dv is None else round(dv, 6)])

    def command(self):
        r = self.r
        cmd = ['rosrun', 'mobile_device_sim', 'run_scenario', os.path.abspath(r.sc.path),
               '--seed', str(r.seed), '--real-time-factor', '%g' % r.rtf]
        if r.replay:
            cmd += ['--replay', os.path.abspath(r.replay)]
        cmd += ['--report', os.path.abspath(self.dir)]
        return ' '.join(shlex.quote(c) for c in cmd)

    def _frame_marks(self, d):
        marks = [(ev['t'], '%s (%s)' % (ev['id'], ev['action']), 'event') for ev in d['events']]
        for v in d['verdicts']:
            if v['t'] is not None:
                marks.append((v['t'], '%s %s' % (v['status'], v['name']), 'verdict'))
        seen, out = set(), []
        for m in sorted(marks, key=lambda m: (m[0], m[2], m[1])):
            if (round(m[0], 6), m[1]) not in seen:
                seen.add((round(m[0], 6), m[1]))
                out.append(m)
        return out[:MAX_MARKS]

    def _overlays(self, topic, w, h):
        """SVG outlines of the regions checked on this topic."""
        o = []
        for e in self.exps:
            if e.topic == topic and 'region' in e.pred.spec:
                x, y, rw, rh = (float(a) for a in e.pred.spec['region'])
                o.append('<rect class="region" x="%g" y="%g" width="%g" height="%g" '
                         'fill="none" stroke="#ff00ff" stroke-width="%g"><title>%s: region %s'
                         '</title></rect>' % (x, y, rw, rh, max(2.0, w / 160.0), _esc(e.name),
                                               _esc(e.pred.spec['region'])))
        return o

    def _save_frame(self, d, topic, item, cache):
        import numpy as np
        from PIL import Image
        t, arr, (w, h) = item
        key = (topic, round(t, 6))
        if key not in cache:
            name = 'img/%s_%09d.jpg' % (slug(topic), int(round(t * 1e6)))
            Image.fromarray(np.ascontiguousarray(arr)).save(os.path.join(self.dir, name),
                                                            quality=82)
            cache[key] = name
            d['frames'].append(dict(topic=topic, t=round(t, 6), file=name, width=w, height=h))
        return cache[key]

    def _figure(self, src, w, h, caption, overlays, cls='', show_w=SHOW_W):
        sw = min(w, show_w) if w >= h else max(1, int(min(h, show_w) * w / float(h)))
        return ('<figure class="frame %s"><div class="imgbox"><img src="%s" alt="%s" '
                'width="%d" height="%d"><svg class="overlay" viewBox="0 0 %d %d" '
                'preserveAspectRatio="none">%s</svg></div><figcaption style="max-width: %dpx">'
                '%s</figcaption></figure>'
                % (cls, _esc(src), _esc(caption), sw, int(round(h * sw / float(w))), w, h,
                   ''.join(overlays), max(sw, 160), _esc(caption)))

    def _image_verdict_figures(self, d, cache):
        """The deciding (or last checked) frame of each image expectation, full size, with
        its region or the barcodes zbar found outlined."""
        import numpy as np
        from PIL import Image
        out = {}
        for e in self.exps:
            if not e.pred.is_image:
                continue
            item = self.deciding.get(e.name) or self.last_in_window.get(e.name)
            if item is None:
                continue
            t, msg = item
            from simvid.imageconv import image_to_rgb
            try:
                rgb = np.ascontiguousarray(image_to_rgb(msg))
            except Exception:  # noqa: BLE001
                continue
            h, w = rgb.shape[:2]
            name = 'img/check_%s.jpg' % slug(e.name)
            Image.fromarray(rgb).save(os.path.join(self.dir, name), quality=85)
            d['frames'].append(dict(topic=e.topic, t=round(t, 6), file=name, width=w,
                                    height=h, expectation=e.name))
            ov = self._overlays(e.topic, w, h) if 'region' in e.pred.spec else []
            if 'barcode' in e.pred.spec:
                try:
                    from simvid.barcode import locate
                    for typ, data, poly in locate(rgb, 'rgb8'):
                        ov.append('<polygon class="barcode" points="%s" fill="none" '
                                  'stroke="#ff00ff" stroke-width="%g"><title>%s,%s</title>'
                                  '</polygon>' % (' '.join('%d,%d' % p for p in poly),
                                                  max(2.0, w / 160.0), _esc(typ), _esc(data)))
                except Exception:  # noqa: BLE001 - zbar missing: no outline
                    pass
            kind = 'deciding' if e.name in self.deciding else 'last checked'
            out[e.name] = self._figure(name, w, h, '%s: %s frame of %s at t=%.3f s' % (
                e.name, kind, e.topic, t), ov, 'check', 420)
        return out

    def _write(self, result, out):
        os.makedirs(os.path.join(self.dir, 'img'), exist_ok=True)
        d = self.data(result)
        cache = {}
        checks = self._image_verdict_figures(d, cache)
        marks = self._frame_marks(d)
        gallery = []
        for t, label, kind in marks:
            figs = []
            for topic, role in self.image_topics.items():
                fr = self.frames.get(topic)
                item = fr.at(t) if fr else None
                if item is None:
                    continue
                src = self._save_frame(d, topic, item, cache)
                w, h = item[2]
                figs.append(self._figure(src, w, h, '%s %s, frame t=%.3f s' % (
                    role, topic, item[0]), self._overlays(topic, w, h)))
            gallery.append((t, label, kind, figs))
        missing = [role for topic, role in self.image_topics.items() if topic not in self.frames]
        page = self._html(d, result, checks, gallery, missing)
        with open(os.path.join(self.dir, 'report.json'), 'w') as f:
            json.dump(d, f, indent=1, sort_keys=True)
        path = os.path.join(self.dir, 'index.html')
        with open(path, 'w') as f:
            f.write(page)
        for name, what in sorted(self.not_numeric.items()):
            e = next(x for x in self.exps if x.name == name)
            out('report: %s: no plot, %s.%s is not numeric (%s)' % (name, e.topic, e.field,
                                                                    what))
        return path

    # -- HTML ------------------------------------------------------------------------------
    def _html(self, d, result, checks, gallery, missing):
        t0 = d['t0']
        t_range = (t0, t0 + d['duration'])
        st = d['status']
        o = [_HEAD % dict(title=_esc('%s: %s' % (d['scenario'], st)))]
        o.append('<header id="summary"><h1>%s <span class="badge status-%s">%s</span></h1>'
                 % (_esc(d['scenario']), st, st))
        if d['description']:
            o.append('<p class="desc">%s</p>' % _esc(d['description']))
        world = d['world'] or {}
        wtext = '%s (%s)%s' % (world.get('launch', 'office'), world.get('physics', 'ode'),
                               ''.join(', %s=%s' % kv for kv in sorted(
                                   (world.get('args') or {}).items())))
        rtf = '%g requested' % d['real_time_factor'] + (
            ', %.2f achieved on the timeline' % d['achieved_rtf'] if d['achieved_rtf'] else '')
        facts = [('scenario file', d['path']), ('run', 'replay of %s' % d['replay']
                                                if d['replay'] else 'live'),
                 ('seed', d['seed']), ('world', wtext), ('real-time factor', rtf),
                 ('sim time', '%.3f s of %.3f s' % (d['sim_time'], d['duration'])),
                 ('wall time', '%.1f s' % d['wall']),
                 ('exit status', '%s (exit code %d)' % (st, d['exit_code'])),
                 ('expectations', '%d passed, %d failed, %d errors' % tuple(
                     sum(1 for v in d['verdicts'] if v['status'] == s)
                     for s in ('PASS', 'FAIL', 'ERROR')))]
        o.append('<table class="facts">%s</table>' % ''.join(
            '<tr><th>%s</th><td>%s</td></tr>' % (_esc(k), _esc(v)) for k, v in facts))
        o.append('<p>Rerun it:</p><pre class="command">%s</pre>' % _esc(d['command']))
        if d['error']:
            o.append('<p class="run-error">ERROR %s</p>' % _esc(d['error']))
        o.append('</header>')
        # verdicts
        o.append('<section id="verdicts"><h2>Verdicts</h2><table class="verdicts"><thead><tr>'
                 '<th>status</th><th>expectation</th><th>expected</th><th>actual</th>'
                 '<th>at sim time</th><th></th></tr></thead><tbody>')
        for v in d['verdicts']:
            if v['plot']:
                name = '<a href="#%s">%s</a>' % (v['plot'], _esc(v['name']))
            elif v['name'] in checks:
                name = '<a href="#check-%s">%s</a>' % (slug(v['name']), _esc(v['name']))
            elif self.values.get(v['name']):
                name = '<a href="#values-%s">%s</a>' % (slug(v['name']), _esc(v['name']))
            else:
                name = _esc(v['name'])
            o.append('<tr class="verdict status-%s" data-status="%s" data-name="%s">'
                     '<td class="status">%s</td><td>%s</td><td>%s</td><td>%s</td><td>%s</td>'
                     '<td class="note">%s</td></tr>' % (
                         v['status'], v['status'], _esc(v['name']), v['status'], name,
                         _esc(v['expected']), _esc(v['actual']),
                         '%.3f s' % v['t'] if v['t'] is not None else '-', _esc(v['note'])))
        o.append('</tbody></table></section>')
        # timeline
        o.append('<section id="timeline"><h2>Timeline</h2>%s<ol class="events">'
                 % self._timeline_svg(d, t_range))
        items = [(e['t'], 'event', '%s: %s%s%s' % (e['id'], e['action'],
                                                  ' "%s"' % e['text'] if e['text'] else '',
                                                  ' (%s)' % e['trigger'] if e['trigger'] else ''))
                 for e in d['events']]
        items += [(v['t'], 'verdict status-%s' % v['status'], '%s %s' % (v['status'],
                                                                         v['name']))
                  for v in d['verdicts'] if v['t'] is not None]
        for t, cls, text in sorted(items, key=lambda x: x[0]):
            o.append('<li class="%s"><span class="t">t=%.3f s</span> %s</li>'
                     % (cls, t, _esc(text)))
        o.append('</ol></section>')
        # plots
        o.append('<section id="plots"><h2>Signals</h2>')
        evs = [(e['t'], '%s (%s)' % (e['id'], e['action'])) for e in d['events']]
        for v in d['verdicts']:
            p = d['plots'].get(v['name'])
            if p is None:
                continue
            band = tuple(p['band']) if p['band'] else None
            o.append('<div class="plot status-%s" id="%s" data-status="%s" data-name="%s">'
                     '<h3>%s <span class="badge status-%s">%s</span></h3><p class="exp">'
                     'expected %s; actual %s</p>%s</div>' % (
                         v['status'], v['plot'], v['status'], _esc(v['name']), _esc(v['name']),
                         v['status'], v['status'], _esc(v['expected']), _esc(v['actual']),
                         svg_plot(p['series'], t_range, p['window'], band, p['decider'],
                                  v['status'], p['ylabel'], evs)))
        for v in d['verdicts']:
            if v['name'] in self.values and self.values[v['name']] and not v['plot']:
                o.append('<div class="values" id="values-%s"><h3>%s: values over sim time'
                         '</h3><p class="note">%s</p><ul>%s</ul></div>' % (
                             slug(v['name']), _esc(v['name']), _esc(v['note']), ''.join(
                                 '<li><span class="t">t=%.3f s</span> %s</li>' % (t, _esc(x))
                                 for t, x in self.values[v['name']])))
        o.append('</section>')
        # images
        o.append('<section id="images"><h2>Camera, display and spectator</h2>')
        o.append('<div class="frames checks">')
        for name, fig in checks.items():
            o.append('<div class="check" id="check-%s"><h3>%s</h3>%s</div>'
                     % (slug(name), _esc(name), fig))
        o.append('</div>')
        if missing:
            o.append('<p class="note">no frames of %s in this run (the flycam: a world '
                     'launched with flycam:=true)</p>' % _esc(', '.join(missing)))
        for t, label, kind, figs in gallery:
            if figs:
                o.append('<div class="moment %s"><h3>t=%.3f s: %s</h3><div class="frames">%s'
                         '</div></div>' % (kind, t, _esc(label), ''.join(figs)))
        o.append('</section>')
        if st == 'ERROR' or result.log_lines:
            o.append('<section id="logs"><h2>Log tails</h2>')
            if result.log_lines:
                o.append('<h3>the run\'s error</h3><pre class="log">%s</pre>'
                         % _esc('\n'.join(result.log_lines)))
            for f, lines in sorted(self.logs.items()):
                o.append('<h3>%s</h3><pre class="log">%s</pre>' % (_esc(f),
                                                                   _esc('\n'.join(lines))))
            o.append('</section>')
        o.append('<script type="application/json" id="report-data">%s</script>'
                 % json.dumps(dict(verdicts=d['verdicts'], status=st)).replace('</', '<\\/'))
        o.append('</body></html>\n')
        return ''.join(o)

    def _timeline_svg(self, d, t_range):
        x0, x1 = t_range
        W, H = PLOT_W, 130
        iw = W - ML - MR

        def X(t):
            return ML + (t - x0) / ((x1 - x0) or 1.0) * iw
        o = ['<svg class="timeline-svg" xmlns="http://www.w3.org/2000/svg" viewBox="0 0 %d %d" '
             'width="%d" height="%d">' % (W, H, W, H)]
        o.append('<line x1="%d" x2="%d" y1="100" y2="100" stroke="#57606a"/>' % (ML, ML + iw))
        for tt in nice_ticks(x0, x1, 8):
            o.append('<line x1="%.1f" x2="%.1f" y1="100" y2="104" stroke="#57606a"/><text '
                     'x="%.1f" y="117" font-size="11" text-anchor="middle" fill="#57606a">%s'
                     '</text>' % (X(tt), X(tt), X(tt), _fmt_num(tt)))
        o.append('<text x="4" y="40" font-size="11" fill="#57606a">events</text><text x="4" '
                 'y="84" font-size="11" fill="#57606a">verdicts</text>')
        for i, e in enumerate(d['events']):
            x = X(e['t'])
            y = 18 + (i % 3) * 12
            o.append('<g class="tl-event"><line x1="%.1f" x2="%.1f" y1="%d" y2="100" '
                     'stroke="#8250df" stroke-dasharray="2 2"/><path d="M%.1f %d l-5 -8 h10 z" '
                     'fill="#8250df"/><text x="%.1f" y="%d" font-size="10" fill="#24292f">%s'
                     '</text><title>t=%.3f s %s %s</title></g>' % (
                         x, x, y, x, y + 8, x + 6, y + 3, _esc(e['id']), e['t'], e['id'],
                         e['action']))
        for i, v in enumerate(x for x in d['verdicts'] if x['t'] is not None):
            x = X(v['t'])
            c = STATUS_COLOURS.get(v['status'], '#24292f')
            o.append('<g class="tl-verdict"><circle cx="%.1f" cy="%d" r="5" fill="%s"/>'
                     '<title>%s %s at t=%.3f s</title></g>' % (x, 72 + (i % 3) * 8, c,
                                                              v['status'], v['name'], v['t']))
        o.append('</svg>')
        return ''.join(o)


_ANSI = re.compile(r'\x1b\[[0-9;]*[A-Za-z]')


def _short(text, n=80):
    return text if len(text) <= n else text[:n - 3] + '...'


_HEAD = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>%(title)s</title>
<style>
body { font-family: sans-serif; margin: 1.2em auto; max-width: 1100px; color: #24292f;
       padding: 0 1em; }
h1 { font-size: 1.5em; margin: 0.2em 0; } h2 { border-bottom: 1px solid #d0d7de;
  padding-bottom: 0.2em; margin-top: 1.4em; } h3 { font-size: 1.05em; margin: 0.8em 0 0.3em; }
.badge { font-size: 0.75em; padding: 0.1em 0.5em; border-radius: 0.8em; color: #fff;
         vertical-align: middle; }
.badge.status-PASS, .verdict.status-PASS .status { background: #1a7f37; }
.badge.status-FAIL, .verdict.status-FAIL .status { background: #cf222e; }
.badge.status-ERROR, .verdict.status-ERROR .status { background: #9a6700; }
table { border-collapse: collapse; } th, td { text-align: left; padding: 0.25em 0.6em;
  vertical-align: top; border-bottom: 1px solid #eaeef2; font-size: 0.92em; }
table.facts th { color: #57606a; font-weight: normal; white-space: nowrap; }
.verdict .status { color: #fff; font-weight: bold; text-align: center; }
.verdict.status-FAIL td, .verdict.status-ERROR td { background-color: #fff5f5; }
.verdict.status-FAIL td.status { background-color: #cf222e; }
.verdict.status-ERROR td.status { background-color: #9a6700; }
pre { background: #f6f8fa; padding: 0.6em; overflow-x: auto; font-size: 0.85em;
      white-space: pre-wrap; word-break: break-all; }
.note { color: #57606a; font-size: 0.9em; } .run-error { color: #9a6700; font-weight: bold; }
ol.events { font-size: 0.9em; } .t { color: #57606a; font-family: monospace; }
li.status-FAIL { color: #cf222e; } li.status-ERROR { color: #9a6700; }
.plot { margin-bottom: 1em; } .plot.status-FAIL { border-left: 4px solid #cf222e;
  padding-left: 0.6em; } .exp { font-size: 0.88em; color: #57606a; margin: 0.2em 0; }
svg { max-width: 100%%; height: auto; display: block; }
.frames { display: flex; flex-wrap: wrap; gap: 0.8em; }
figure.frame { margin: 0; } figure.frame figcaption { font-size: 0.8em; color: #57606a; }
.imgbox { position: relative; display: inline-block; line-height: 0; }
.imgbox img { display: block; max-width: 100%%; height: auto; border: 1px solid #d0d7de; }
.imgbox svg.overlay { position: absolute; left: 0; top: 0; width: 100%%; height: 100%%; }
</style></head><body>
"""


def write_invalid(out_dir, path, problems, out=print):
    """The report of a scenario file that did not validate: its problems, file:line each
    (nothing ran). Never raises: a folder that cannot be written is one line."""
    name = os.path.splitext(os.path.basename(path))[0]
    cmd = ' '.join(shlex.quote(c) for c in ['rosrun', 'mobile_device_sim', 'run_scenario',
                                            os.path.abspath(path), '--report',
                                            os.path.abspath(out_dir)])
    d = dict(scenario=name, path=os.path.abspath(path), status='ERROR', exit_code=2,
             error='invalid scenario file', problems=list(problems), verdicts=[], plots={},
             events=[], frames=[], command=cmd)
    page = [_HEAD % dict(title=_esc('%s: ERROR' % name)),
            '<header id="summary"><h1>%s <span class="badge status-ERROR">ERROR</span></h1>'
            '<p class="run-error">the scenario file %s is invalid: nothing ran</p><ul '
            'class="problems">%s</ul><p>Rerun it:</p><pre class="command">%s</pre></header>'
            '</body></html>\n' % (_esc(name), _esc(d['path']), ''.join(
                '<li>%s</li>' % _esc(p) for p in problems), _esc(cmd))]
    try:
        os.makedirs(out_dir, exist_ok=True)
        with open(os.path.join(out_dir, 'report.json'), 'w') as f:
            json.dump(d, f, indent=1, sort_keys=True)
        with open(os.path.join(out_dir, 'index.html'), 'w') as f:
            f.write(''.join(page))
    except OSError as e:
        out('report: cannot write the report to %s: %s' % (out_dir, e.strerror or e))
        return None
    out('report: %s' % os.path.join(out_dir, 'index.html'))
    return os.path.join(out_dir, 'index.html')


def write_farm_index(out_dir, runs, wall, out):
    """write_index for a farm (--jobs, --sweep, --cluster); never raises: one line through
    ``out`` naming the page, or why it could not be written."""
    try:
        out('report: %s' % write_index(out_dir, runs, wall))
    except OSError as e:
        out('report: cannot write the farm index to %s: %s' % (out_dir, e.strerror or e))


def write_index(out_dir, runs, wall=None):
    """A farm's index page: one row per run (name, seed, status, wall s, expectations, link
    to its report) and the totals. runs: [{name, status, wall, report (folder)}]."""
    rows = []
    totals = {'PASS': 0, 'FAIL': 0, 'ERROR': 0}
    n_exp = n_pass = 0
    for run in sorted(runs, key=lambda r: r['name']):
        info = {}
        rep = run.get('report')
        if rep:
            try:
                with open(os.path.join(rep, 'report.json')) as f:
                    info = json.load(f)
            except (OSError, ValueError):
                info = {}
        st = run.get('status') or info.get('status') or 'ERROR'
        totals[st] = totals.get(st, 0) + 1
        vs = info.get('verdicts', [])
        n_exp += len(vs)
        n_pass += sum(1 for v in vs if v['status'] == 'PASS')
        link = os.path.relpath(os.path.join(rep, 'index.html'), out_dir) if info else None
        failed = ', '.join(v['name'] for v in vs if v['status'] != 'PASS')
        rows.append('<tr class="run status-%s" data-status="%s"><td class="status">%s</td>'
                    '<td>%s</td><td>%s</td><td>%.1f</td><td>%d/%d</td><td>%s</td></tr>' % (
                        st, st, st, ('<a href="%s">%s</a>' % (_esc(link), _esc(run['name']))
                                     if link else _esc(run['name'])),
                        _esc(info.get('seed', '-')), float(run.get('wall') or 0.0),
                        sum(1 for v in vs if v['status'] == 'PASS'), len(vs), _esc(failed)))
    o = [_HEAD % dict(title='scenario farm: %d runs' % len(runs))]
    o.append('<header id="summary"><h1>Scenario farm</h1><p class="totals">%d runs: %d PASS, '
             '%d FAIL, %d ERROR; %d of %d expectations passed%s</p></header>' % (
                 len(runs), totals['PASS'], totals['FAIL'], totals['ERROR'], n_pass, n_exp,
                 '; %.1f s wall' % wall if wall is not None else ''))
    o.append('<table class="verdicts runs"><thead><tr><th>status</th><th>scenario</th>'
             '<th>seed</th><th>wall s</th><th>expectations passed</th><th>not passed</th>'
             '</tr></thead><tbody>%s</tbody></table></body></html>\n' % ''.join(rows))
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, 'index.html')
    with open(path, 'w') as f:
        f.write(''.join(o).replace('class="run status-', 'class="verdict run status-'))
    return path
