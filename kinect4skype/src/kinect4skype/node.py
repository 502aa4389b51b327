"""The pcl2image ROS node (thesis section 4.4.2, kinect4skype).

Subscribes ``input`` (sensor_msgs/PointCloud2: x y z with or without rgb) and
``~viewpoint`` (geometry_msgs/Pose: the virtual camera's optical frame in the cloud's
frame), renders offscreen through the project's OSMesa renderer and publishes ``image``
(sensor_msgs/Image, rgb8, stamped like the cloud).

Private parameters:
  ~width, ~height   (640, 480)     image size
  ~hfov             (1.0472)       horizontal field of view, radians
  ~viewpoint        ([0,0,0,0,0,0]) x y z roll pitch yaw of the virtual camera's optical
                                   frame (x right, y down, looking along +z) in the cloud's
                                   frame; the default is the sensor's own view
  ~point_size       (2.0)          pixels
  ~color_mode       (auto)         rgb (the cloud's rgb field), depth (colour map, near red
                                   to far blue) or auto (rgb when the cloud has it)
  ~depth_range      ([0, 0])       metres mapped by the depth colour map; [0, 0] = from
                                   each cloud
  ~background       ([0, 0, 0])    rgb 0..1
  ~frame_id         ('')           image frame_id; empty = the cloud's frame_id
"""
import math
import threading

import numpy as np
import rospy
from geometry_msgs.msg import Pose as PoseMsg
from sensor_msgs.msg import Image, PointCloud2

from simvid.imageconv import array_to_image
from sim_world.logonce import LogOnce
from sim_world.transforms import Pose

from .cloud import UnsupportedCloud, cloud_to_arrays
from .render import COLOR_MODES, PointCloudRenderer, viewpoint_from_list


class Pcl2Image(object):
    def __init__(self, renderer, publish, frame_id='', log_error=None):
        self.r = renderer
        self.publish = publish
        self.frame_id = frame_id
        self.lock = threading.Lock()
        self.last = None          # (xyz, rgb, header) of the last good cloud
        # a problem once, again only after it went away or changed (not at the cloud rate)
        self.cloud_err = LogOnce(say=log_error or (lambda m: None), until_changed=True)
        self.pose_err = LogOnce(say=log_error or (lambda m: None), until_changed=True)
        self.images = 0

    def on_cloud(self, msg):
        try:
            xyz, rgb = cloud_to_arrays(msg)
        except UnsupportedCloud as e:
            self.cloud_err.problem('pcl2image: %s; cloud ignored' % e)
            return None
        if self.r.color_mode == 'rgb' and rgb is None:
            self.cloud_err.problem('pcl2image: color_mode is rgb but the cloud has no rgb field '
                                   '(fields: %s); drawing it with the depth colour map'
                                   % ', '.join(f.name for f in msg.fields))
        else:
            self.cloud_err.ok()
        with self.lock:
            self.last = (xyz, rgb, msg.header)
            return self._render()

    def on_pose(self, msg):
        try:
            pose = Pose.from_msg(msg)
            q = np.array(pose.q, float)
            vals = np.r_[pose.p, q]
            if not np.isfinite(vals).all():
                raise ValueError('non-finite value')
        except Exception as e:  # noqa: BLE001 - Pose raises on zero quaternions
            self.pose_err.problem('pcl2image: viewpoint pose rejected (%s); keeping the '
                                  'previous viewpoint' % e)
            return None
        self.pose_err.ok()
        with self.lock:
            self.r.set_viewpoint(pose)
            if self.last is not None:
                return self._render()
        return None

    def _render(self):
        xyz, rgb, header = self.last
        if self.r.mode_for(rgb) == 'rgb' and rgb is None:
            img = self.r.render(xyz, self.r.depth_colors(xyz))
        else:
            img, _ = self.r.render_cloud(xyz, rgb)
        msg = array_to_image(img, 'rgb8', stamp=header.stamp,
                             frame_id=self.frame_id or header.frame_id)
        self.publish(msg)
        self.images += 1
        return img


def _param_list(name, default, n):
    v = rospy.get_param(name, default)
    try:
        v = [float(a) for a in v]
        if len(v) != n or not all(math.isfinite(a) for a in v):
            raise ValueError
        return v
    except (TypeError, ValueError):
        rospy.logerr('pcl2image: %s must be a list of %d numbers, got %r; using %r',
                     name, n, v, default)
        return list(default)


def main(argv=None):
    rospy.init_node('pcl2image', argv=argv)
    width = rospy.get_param('~width', 640)
    height = rospy.get_param('~height', 480)
    hfov = rospy.get_param('~hfov', math.radians(60))
    point_size = rospy.get_param('~point_size', 2.0)
    color_mode = rospy.get_param('~color_mode', 'auto')
    frame_id = rospy.get_param('~frame_id', '')
    vp = _param_list('~viewpoint', [0.0] * 6, 6)
    depth_range = _param_list('~depth_range', [0.0, 0.0], 2)
    background = _param_list('~background', [0.0, 0.0, 0.0], 3)
    if color_mode not in COLOR_MODES:
        rospy.logerr('pcl2image: ~color_mode must be one of %s, got %r; using auto',
                     ', '.join(COLOR_MODES), color_mode)
        color_mode = 'auto'
    try:
        width, height = int(width), int(height)
        if not (0 < width <= 8192 and 0 < height <= 8192):
            raise ValueError
    except (TypeError, ValueError):
        rospy.logerr('pcl2image: ~width/~height must be 1..8192, got %r x %r; using 640x480',
                     width, height)
        width, height = 640, 480
    try:
        hfov = float(hfov)
        if not 0 < hfov < math.pi:
            raise ValueError
    except (TypeError, ValueError):
        rospy.logerr('pcl2image: ~hfov must be in (0, pi) radians, got %r; using 1.0472', hfov)
        hfov = math.radians(60)
    try:
        point_size = float(point_size)
        if not point_size > 0:
            raise ValueError
    except (TypeError, ValueError):
        rospy.logerr('pcl2image: ~point_size must be positive, got %r; using 2', point_size)
        point_size = 2.0
    renderer = PointCloudRenderer(width, height, hfov, viewpoint_from_list(vp), point_size,
                                  color_mode, depth_range, background)
    pub = rospy.Publisher('image', Image, queue_size=2)
    node = Pcl2Image(renderer, pub.publish, frame_id, log_error=rospy.logerr)
    rospy.Subscriber('input', PointCloud2, node.on_cloud, queue_size=1, buff_size=1 << 25)
    rospy.Subscriber('~viewpoint', PoseMsg, node.on_pose, queue_size=1)
    rospy.loginfo('pcl2image: %s -> %s (%dx%d, hfov %.3f rad, point size %g, colour %s)',
                  rospy.resolve_name('input'), rospy.resolve_name('image'), width, height,
                  hfov, point_size, color_mode)
    rospy.spin()
    return 0
