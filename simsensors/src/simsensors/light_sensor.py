"""The ambient light sensor of thesis section 3.3.12: ``libgazebo_ros_light_sensor.so``.

Illuminance (lux) on the front face of the phone (the +z axis of ``bodyName``; on the phone
the sensor link ``mobile_proximity_sensor`` beside the earpiece) from the world's lights,
each through its direction, its distance and what is in between:

* point and spot lights (``world.lights``, SDF ``<light type="point|spot">``): photometric
  inverse-square law ``E = I cos(theta) / r^2`` with the luminous intensity ``I`` =
  ``candelaPerUnit`` x the luminance of the light's diffuse colour (Rec. 709 weights) x, for
  a spot, its cone factor towards the sensor (``Light.spot_factor``: SDF ``<spot>`` inner and
  outer angle and falloff, Gazebo's definition, the one the renderer approximates), zero
  beyond the light's ``<attenuation><range>`` and where a ray from the sensor to the light
  hits the world's collision geometry (``world.raycast``, the phone itself ignored).
  Calibration: ``candelaPerUnit`` 1500 cd makes a white light (diffuse 1 1 1) a typical
  ceiling luminaire (two 36 W fluorescent tubes, about 6000 lm, about 1500 cd downwards);
  the office's ceiling light (diffuse 0.6) gives about 300-500 lux on the desk, an office's
  usual 500 lux (EN 12464-1) order;
* daylight: directional lights are the sun. Outdoors (outside every indoor volume of the
  environment) the face receives the environment's ``daylight`` (lux, horizontal outdoor
  illuminance) split into a direct part ``cos(theta)`` towards each directional light (if
  no geometry is in the way) and a sky part ``skyFraction`` x (1 + n_z) / 2 (the share of
  the sky dome a tilted face sees), normalised so a face up in open sun reads ``daylight``.
  Indoors, daylight arrives only within the margin of an opening (door, window) of the
  indoor volume, scaled by ``openingFactor``;
* indirect light: ``ambientLux`` x the luminance of the scene's ambient colour, times the
  fraction of five rays (the normal and four at 45 degrees) that leave the face for at least
  ``occlusionDistance`` m (face down on a desk: all blocked, about 0 lux).

The colour composition (``light_color``, std_msgs/ColorRGBA): the lux-weighted mean of the
contributing lights' diffuse colours, each scaled to a maximum channel of 1 (sky: 0.75 0.85 1,
ambient: the scene's ambient colour); a = 1, or all 0 in the dark.

Why ray casts and not a rendered image (the thesis's suggestion): measured by
``bench/light_sensor`` in one run (simsensors/README.md): one reading costs a few ray casts
(well under a millisecond) against an offscreen render of even a small 16x16 view plus the
read-back of several milliseconds with llvmpipe, and the render's pixel values carry no
photometric scale (they are the materials' shaded colours, saturated at 1).

Android's ``Sensor.TYPE_LIGHT`` reports lux as well: no conversion. Noise: the Android CDD
asks for nothing beyond reporting lux; the default is a 1 % relative jitter
(``scaleGaussianNoise`` 0.01; ``gaussianNoise``, ``offset`` ... are in lux) and a
quantisation (``quantization``) of 1 lux. Default 5 Hz.
"""
import math

import numpy as np

from sim_world.plugins import register
from sim_world.plugins.params import Param
from sim_world.plugins.sensor import Sensor

__all__ = ['LightSensor', 'luminance', 'SKY_COLOR']

REC709 = np.array([0.2126, 0.7152, 0.0722])
SKY_COLOR = np.array([0.75, 0.85, 1.0])
#: the normal and four directions 45 degrees off it (in the sensor's frame) for occlusion
_AO_DIRS = np.array([[0, 0, 1.0]] + [[math.cos(a) * 0.70710678, math.sin(a) * 0.70710678,
                                      0.70710678] for a in (0, math.pi / 2, math.pi,
                                                            3 * math.pi / 2)])


def luminance(rgb):
    return float(np.dot(np.asarray(rgb, float)[:3], REC709))


def _unit_color(rgb):
    c = np.clip(np.asarray(rgb, float)[:3], 0.0, None)
    m = c.max()
    return c / m if m > 0 else c


@register('libgazebo_ros_light_sensor.so', 'libgazebo_ros_illuminance.so')
class LightSensor(Sensor):
    DEFAULT_TOPIC = 'illuminance'
    DEFAULT_RATE = 5.0
    ERRORS = {'': dict(dims=1, quantization=1.0),
              'scale': dict(dims=1, gaussian_noise=0.01)}
    PARAMS = [
        Param('candelaPerUnit', float, 1500.0, aliases=('candela_per_unit',), unit='cd',
              check='>=0', doc='luminous intensity of a light with diffuse luminance 1'),
        Param('ambientLux', float, 200.0, aliases=('ambient_lux',), unit='lx', check='>=0',
              doc='indirect light per unit of the scene ambient luminance'),
        Param('skyFraction', float, 0.2, aliases=('sky_fraction',), check=(0.0, 1.0),
              doc='share of outdoor daylight that comes from the sky dome'),
        Param('openingFactor', float, 0.1, aliases=('opening_factor',), check=(0.0, 1.0),
              doc='share of daylight within the margin of an opening of an indoor volume'),
        Param('occlusionDistance', float, 0.5, aliases=('occlusion_distance',), unit='m',
              check='>0'),
        Param('colorTopicName', str, 'light_color', aliases=('color_topic',)),
    ]

    def setup(self):
        from sensor_msgs.msg import Illuminance
        from std_msgs.msg import ColorRGBA
        self.Illuminance, self.ColorRGBA = Illuminance, ColorRGBA
        self.output('main', Illuminance)
        # the colour composition carries no noise: a noise fault leaves it as it is
        self.color_pub = self.output('color', ColorRGBA, topic=self.p.colorTopicName,
                                     noisy=False)

    # -- geometry ---------------------------------------------------------------------------------
    def _blocked(self, origin, direction, dist):
        return self.world.raycast(origin, direction, dist,
                                  ignore=(self.model.name,)) is not None

    def contributions(self, p, n, rot):
        """[(lux, rgb, name)] of everything lighting the face at world point p with normal n;
        rot: world rotation of the sensor frame (for the occlusion rays)."""
        out = []
        env = self.env
        origin = p + n * 1e-4
        daylight = float(env.get('daylight') or 0.0)
        inside, _, in_margin = env.indoor(p)
        day = daylight if not inside else (daylight * self.p.openingFactor if in_margin else 0.0)
        suns = [lt for lt in self.world.lights if lt.kind == 'directional']
        if day > 0 and suns:
            weights = np.array([max(luminance(lt.diffuse), 0.0) for lt in suns])
            if weights.sum() > 0:
                weights = weights / weights.sum()
            sky = self.p.skyFraction
            # normalise: a face up in open sun reads `day`
            dirs = []
            for lt in suns:
                d = lt.pose.rotate(lt.direction)
                dn = np.linalg.norm(d)
                dirs.append(d / dn if dn > 1e-9 else np.array([0.0, 0.0, -1.0]))
            up_cos = sum(w * max(0.0, -d[2]) for w, d in zip(weights, dirs))
            k_sun = (1.0 - sky) / up_cos if up_cos > 1e-6 else 0.0
            for lt, w, d in zip(suns, weights, dirs):
                c = float(np.dot(n, -d))
                if c <= 0 or w <= 0:
                    continue
                if self._blocked(origin, -d, 1000.0):
                    continue
                out.append((day * k_sun * w * c, _unit_color(lt.diffuse), lt.name))
            sky_view = (1.0 + n[2]) / 2.0
            if sky_view > 0 and sky > 0:
                out.append((day * sky * sky_view, SKY_COLOR, 'sky'))
        for lt in self.world.lights:
            if lt.kind == 'directional':
                continue
            v = np.asarray(lt.pose.p, float) - p
            r = float(np.linalg.norm(v))
            if r < 1e-6 or r > float(lt.range):
                continue
            c = float(np.dot(n, v / r))
            if c <= 0:
                continue
            cone = lt.spot_factor(-v)            # 1 for point lights
            if cone <= 0:
                continue
            if self._blocked(origin, v / r, r - 1e-3):
                continue
            intensity = self.p.candelaPerUnit * max(luminance(lt.diffuse), 0.0) * cone
            out.append((intensity * c / max(r * r, 1e-4), _unit_color(lt.diffuse), lt.name))
        amb = np.asarray(self.world.ambient, float)[:3]
        amb_lux = self.p.ambientLux * luminance(amb)
        if amb_lux > 0:
            free = sum(0 if self._blocked(origin, rot(dv), self.p.occlusionDistance) else 1
                       for dv in _AO_DIRS)
            if free:
                out.append((amb_lux * free / float(len(_AO_DIRS)), _unit_color(amb), 'ambient'))
        return out

    def measure(self, state, dt):
        pose = state.body_pose
        n = pose.rotate(np.array([0.0, 0.0, 1.0]))
        parts = self.contributions(np.asarray(pose.p, float), n, pose.rotate)
        lux = sum(e for e, _, _ in parts)
        color = np.zeros(3)
        if lux > 0:
            color = sum(e * c for e, c, _ in parts) / lux
        self.parts = parts
        jitter = float(self.errors['scale'].apply(np.zeros(1))[0])   # relative, this tick
        noisy = max(0.0, float(self.errors[''].apply(np.array([lux * (1.0 + jitter)]))[0]))
        return noisy, color, lux

    def messages(self, value, stamp):
        _, color, lux = value
        m = self.ColorRGBA()
        m.r, m.g, m.b = (float(x) for x in color)
        m.a = 1.0 if lux > 0 else 0.0
        return {'main': lambda: self.to_msg(value, stamp), 'color': m}

    def to_msg(self, value, stamp):
        lux = value[0]
        m = self.Illuminance()
        m.header.stamp = stamp
        m.header.frame_id = self.frame_id
        m.illuminance = lux
        var = float(self.errors[''].variance[0]) + float(self.errors['scale'].variance[0]) * lux ** 2
        m.variance = var
        return m
