"""One error model for every scalar and vector sensor value.

The model of hector_gazebo_plugins' ``SensorModel`` (offset, drift as a first-order
Gauss-Markov process, drift frequency, Gaussian noise, scale error) joined with SDF's
``<noise>`` (mean, stddev, bias_mean, bias_stddev, dynamic_bias_stddev,
dynamic_bias_correlation_time, precision)::

    y = scale * x + offset + bias + drift(t) + noise,   then quantised to ``quantization``

- ``bias`` is drawn at start and at every ``reset()`` from N(bias_mean, bias_stddev) with a
  random sign (as Gazebo does);
- ``drift`` is a first-order Gauss-Markov process with stationary standard deviation
  ``drift`` and correlation time 1/``drift_frequency``, discretised exactly for any step dt:
  d' = a d + drift sqrt(1 - a^2) w, a = exp(-dt drift_frequency); its first value is drawn
  from the stationary distribution; drift_frequency 0 means a constant drift drawn at reset;
- ``noise`` is white Gaussian with standard deviation ``gaussian_noise`` (times
  ``noise_scale``, which fault injection raises).

Every draw comes from the ``rng`` given (a numpy Generator from the world's seed); each
``step`` draws the same number of values whatever the parameters' sizes, so streams stay
aligned by sample index. ``variance`` is the per-axis variance of y - scale x about its mean
(noise, drift, bias spread, quantisation), for messages' covariance fields.
"""
import math

import numpy as np

from .params import Param, ParamError

__all__ = ['ErrorModel', 'FieldNoise', 'error_params', 'error_model_from', 'HECTOR_FIELDS']

#: hector names (after the channel prefix) -> ErrorModel keyword
HECTOR_FIELDS = (
    ('offset', 'offset', 'value unit'),
    ('drift', 'drift', 'value unit'),
    ('driftFrequency', 'drift_frequency', 'Hz'),
    ('gaussianNoise', 'gaussian_noise', 'value unit'),
    ('scaleError', 'scale_error', '1'),
    ('quantization', 'quantization', 'value unit'),
    ('biasMean', 'bias_mean', 'value unit'),
    ('biasStddev', 'bias_stddev', 'value unit'),
)


class ErrorModel(object):
    def __init__(self, dims=1, offset=0.0, drift=0.0, drift_frequency=0.0, gaussian_noise=0.0,
                 scale_error=1.0, bias_mean=0.0, bias_stddev=0.0, quantization=0.0, rng=None):
        self.dims = int(dims)
        shape = (self.dims,)

        def arr(v):
            a = np.broadcast_to(np.asarray(v, float), shape).astype(float)
            return a

        self.offset = arr(offset)
        self.drift = arr(drift)
        self.drift_frequency = arr(drift_frequency)
        self.gaussian_noise = arr(gaussian_noise)
        self.scale_error = arr(scale_error)
        self.bias_mean = arr(bias_mean)
        self.bias_stddev = arr(bias_stddev)
        self.quantization = arr(quantization)
        for name in ('drift', 'drift_frequency', 'gaussian_noise', 'bias_stddev',
                     'quantization'):
            if np.any(getattr(self, name) < 0):
                raise ValueError('%s must be >= 0' % name)
        self.noise_scale = 1.0
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.identity = not (np.any(self.offset) or np.any(self.drift) or
                             np.any(self.gaussian_noise) or np.any(self.scale_error != 1.0) or
                             np.any(self.bias_mean) or np.any(self.bias_stddev) or
                             np.any(self.quantization))
        self.current_drift = np.zeros(shape)
        self.current_noise = np.zeros(shape)
        self.bias = np.zeros(shape)
        self.reset()

    # -- state -------------------------------------------------------------------------------
    def reset(self):
        """New bias and a drift state from the stationary distribution."""
        z = self.rng.standard_normal(2 * self.dims)
        sign = np.where(self.rng.random(self.dims) < 0.5, -1.0, 1.0)
        self.bias = sign * (self.bias_mean + self.bias_stddev * z[:self.dims])
        self.current_drift = self.drift * z[self.dims:]
        self.current_noise = np.zeros(self.dims)

    def step(self, dt):
        """Advance the drift by dt seconds of sim time and draw this sample's noise."""
        z = self.rng.standard_normal(2 * self.dims)
        if np.asarray(self.drift).any():
            f = self.drift_frequency
            a = np.exp(-np.maximum(dt, 0.0) * f)
            self.current_drift = a * self.current_drift + \
                self.drift * np.sqrt(np.maximum(0.0, 1.0 - a * a)) * z[self.dims:]
        self.current_noise = self.gaussian_noise * self.noise_scale * z[:self.dims]

    def apply(self, x):
        """The perturbed value of x with the current drift and noise (same shape as x;
        a scalar model gives a float)."""
        if self.identity and self.noise_scale == 1.0:
            return x
        v = np.asarray(x, float)
        scalar = v.ndim == 0
        y = v * self.scale_error + self.offset + self.bias + self.current_drift + \
            self.current_noise
        q = self.quantization
        if np.asarray(q).any():
            y = np.where(q > 0, np.round(y / np.where(q > 0, q, 1.0)) * q, y)
        if scalar or (self.dims == 1 and v.shape == ()):
            return float(y[0])
        return y.reshape(v.shape) if v.shape else y

    def __call__(self, x, dt):
        self.step(dt)
        return self.apply(x)

    @property
    def variance(self):
        return (self.gaussian_noise * self.noise_scale) ** 2 + self.drift ** 2 + \
            self.bias_stddev ** 2 + self.quantization ** 2 / 12.0

    def __repr__(self):
        return ('ErrorModel(dims=%d, offset=%s, drift=%s@%sHz, noise=%s, scale=%s, bias=%s+-%s,'
                ' q=%s)' % (self.dims, self.offset, self.drift, self.drift_frequency,
                            self.gaussian_noise, self.scale_error, self.bias_mean,
                            self.bias_stddev, self.quantization))


class FieldNoise(object):
    """One tick of a scalar ``ErrorModel`` applied to every sample of a field: a camera's
    pixels, values 0..1 (uint8 0..255), as Gazebo's camera ``<noise>`` (amplifier noise)::

        y = clip(scale x + offset + bias + drift + sigma n, 0, 1),   quantised

    with one standard normal ``n`` per pixel, added to each of its channels (Gazebo draws a
    value per pixel and adds it to every colour channel), ``sigma`` the model's
    ``gaussian_noise`` times its ``noise_scale`` (a ``noise`` fault). The parameters are
    those of the tick it is made at; its draws come from a generator seeded with ``seed``
    (drawn from the sensor's generator at that tick), so a frame's noise is the same
    whatever thread applies it and whenever. ``identity``: nothing to do (no ``<noise>``):
    the image stays the very same array."""
    __slots__ = ('scale', 'shift', 'sigma', 'quantization', 'seed', 'identity')

    def __init__(self, model, seed=0):
        self.identity = bool(model.identity and model.noise_scale == 1.0)
        self.scale = float(model.scale_error[0])
        self.shift = float(model.offset[0] + model.bias[0] + model.current_drift[0])
        self.sigma = float(model.gaussian_noise[0] * model.noise_scale)
        self.quantization = float(model.quantization[0])
        self.seed = int(seed)

    def apply_uint8(self, img):
        """The noisy copy of an HxW(xC) uint8 image (values 0..255 for 0..1)."""
        if self.identity:
            return img
        img = np.asarray(img)
        y = img.astype(np.float32) * np.float32(self.scale / 255.0)
        y += np.float32(self.shift)
        if self.sigma > 0:
            n = np.random.default_rng(self.seed).standard_normal(img.shape[:2], np.float32)
            n *= np.float32(self.sigma)
            y += n[..., None] if img.ndim == 3 else n
        if self.quantization > 0:
            q = np.float32(self.quantization)
            y = np.round(y / q) * q
        np.clip(y, 0.0, 1.0, out=y)
        y *= np.float32(255.0)
        return np.rint(y, out=y).astype(np.uint8)


def _prefixed(prefix, field):
    if not prefix:
        return field
    return prefix + field[0].upper() + field[1:]


class _Numbers(object):
    """Param type: one number or ``dims`` numbers."""

    def __init__(self, dims):
        self.dims = dims
        self.what = 'one number' if dims == 1 else 'one number or %d numbers' % dims

    def __call__(self, text):
        vals = [float(x) for x in text.replace(',', ' ').split()]
        if len(vals) not in (1, self.dims) or not all(math.isfinite(v) for v in vals):
            raise ValueError(self.what)
        return vals[0] if len(vals) == 1 else np.array(vals)


def error_params(prefix='', dims=1, defaults=None, aliases=None):
    """Param rows of one channel's error model: hector's names with the channel prefix
    (``accelGaussianNoise``; no prefix: ``gaussianNoise``), each accepting one number or one
    per axis. ``aliases`` maps a field to further names (e.g. {'gaussianNoise':
    ('noise',)})."""
    defaults = defaults or {}
    aliases = aliases or {}
    kind = _Numbers(dims)
    rows = []
    for field, kw, unit in HECTOR_FIELDS:
        d = defaults.get(kw, 1.0 if kw == 'scale_error' else 0.0)
        check = None if kw in ('offset', 'bias_mean', 'scale_error') else '>=0'
        al = tuple(_prefixed(prefix, a) for a in aliases.get(field, ()))
        rows.append(Param(_prefixed(prefix, field), kind, d, aliases=al, unit=unit,
                          check=check, doc='error model: %s' % kw))
    return rows


def _sdf_noise(el, dims):
    """ErrorModel keywords from an SDF <noise> element ({} if it is 'none'); ParamError
    saying which child is wrong (not a number, or negative where a spread must not be)."""
    from .params import _local

    def num(tag, default=0.0, nonneg=True):
        for c in el:
            if _local(c.tag) == tag and c.text and c.text.strip():
                try:
                    v = float(c.text)
                except ValueError:
                    v = math.nan
                if not math.isfinite(v) or (nonneg and v < 0):
                    raise ParamError('<%s> must be %s, got %r' % (
                        tag, 'a number >= 0' if nonneg else 'a number', c.text.strip()))
                return v
        return default

    t = el.get('type')
    if t is None:              # SDF 1.4's camera and ray <noise>: <type> is a child element
        t = next((c.text.strip() for c in el if _local(c.tag) == 'type' and c.text), None)
    t = t or 'gaussian'
    if t == 'none':
        return {}
    if t not in ('gaussian', 'gaussian_quantized'):
        raise ParamError('type must be gaussian, gaussian_quantized or none, got %r' % t)
    kw = dict(offset=num('mean', nonneg=False), gaussian_noise=num('stddev'),
              bias_mean=num('bias_mean', nonneg=False), bias_stddev=num('bias_stddev'),
              drift=num('dynamic_bias_stddev'))
    tc = num('dynamic_bias_correlation_time', 0.0)
    if kw['drift'] > 0:
        kw['drift_frequency'] = 1.0 / tc if tc > 0 else 0.0
    if t == 'gaussian_quantized':
        kw['quantization'] = num('precision')
    return kw


def _find_noise(spec, paths):
    from .params import _local
    for path in paths:
        for parent in (spec.element, spec.sensor):
            cur = parent
            for name in path:
                if cur is None:
                    break
                cur = next((c for c in cur if _local(c.tag) == name), None)
            if cur is not None:
                return cur
    return None


def error_model_from(values, prefix='', dims=1, rng=None, spec=None, sdf_paths=(),
                     defaults=None):
    """ErrorModel from parsed ``values`` (see error_params); an SDF ``<noise>`` element at
    one of ``sdf_paths`` (tuples of tag names below the plugin or sensor element) overrides
    the fields it sets. Raises ParamError (what is wrong) for a bad SDF element."""
    kw = {}
    for field, k, _ in HECTOR_FIELDS:
        kw[k] = values[_prefixed(prefix, field)]
    if kw['drift'] is not None and np.any(np.asarray(kw['drift']) > 0) and \
            not np.any(np.asarray(kw['drift_frequency']) > 0) and \
            _prefixed(prefix, 'driftFrequency') not in values.given:
        kw['drift_frequency'] = (defaults or {}).get('drift_frequency', 1.0 / 3600.0)
    if spec is not None and sdf_paths:
        el = _find_noise(spec, sdf_paths)
        if el is not None:
            kw.update(_sdf_noise(el, dims))
    return ErrorModel(dims=dims, rng=rng, **kw)
