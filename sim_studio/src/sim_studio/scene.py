"""What the 3D view draws: each model's links and their visuals (boxes, cylinders, spheres,
planes; a mesh is drawn as its bounding box in this first version), read with sim_world's
own loaders (sdf.load_world_file for the world file, urdf.parse_urdf for a spawned model's
description), and the link poses at the model's rest pose (its joints at zero)."""
import logging

import numpy as np

from sim_world.transforms import Pose

__all__ = ['describe_model', 'describe_world_file', 'describe_urdf', 'link_poses', 'display_of']


def _pose(p):
    return {'position': [float(v) for v in p.p], 'orientation': [float(v) for v in p.q]}


def _geometry(g):
    out = {'kind': g.kind}
    if g.kind == 'box':
        out['size'] = [float(v) for v in g.size]
    elif g.kind == 'cylinder':
        out.update(radius=g.radius, length=g.length)
    elif g.kind == 'sphere':
        out['radius'] = g.radius
    elif g.kind == 'plane':
        size = [float(v) for v in g.size[:2]]
        out['size'] = [s if s > 0 else 100.0 for s in size]
    else:                    # mesh: approximated (its scale as a box) in this version
        out = {'kind': 'box', 'size': [float(v) * 0.1 for v in g.scale], 'mesh': g.filename}
    return out


def link_poses(model):
    """{link name: Pose in the model's frame} with every joint at zero."""
    root_name = model.root_link or next(iter(model.links), None)
    poses = {root_name: Pose()} if root_name is not None else {}
    pending = list(model.joints)
    while pending:
        left = []
        for j in pending:
            if j.parent in poses:
                poses[j.child] = poses[j.parent] * j.origin
            else:
                left.append(j)
        if len(left) == len(pending):
            break
        pending = left
    for name in model.links:
        poses.setdefault(name, Pose())
    return poses


def describe_model(model):
    """{'name', 'static', 'links': [{'name', 'pose' (in the model frame), 'visuals'}]}."""
    links = []
    for name, pose in link_poses(model).items():
        link = model.links.get(name)
        if link is None:
            continue
        visuals = []
        for v in link.visuals:
            rgba = [float(c) for c in np.asarray(v.material.rgba, float)[:4]]
            visuals.append({'geometry': _geometry(v.geometry), 'origin': _pose(v.origin),
                            'rgba': rgba})
        links.append({'name': name, 'pose': _pose(pose), 'visuals': visuals})
    out = {'name': model.name, 'static': bool(model.static), 'links': links,
           'pose': _pose(model.pose)}
    display = display_of(model)
    if display is not None:
        out['display'] = display
    return out


class _NoWorld(object):
    """What the video texture plugin's ``load`` reads of a world when ROS is off: its
    parameters are read and its texture sized, nothing is subscribed."""
    ros_enabled = False
    sim_time = 0.0
    log = logging.getLogger('sim_studio.scene')


def display_of(model):
    """The touch display of ``model`` as its plugins see it: {'link', 'width', 'height'
    (px, the coordinates of ``inject_touch`` and of the touch events), 'image_topic' (what
    the display shows, None without a video texture)}; None for a model without a touch
    screen. The size is the touch plugin's own rule, from the same parameter rows and
    code: ``displayWidth``/``displayHeight`` of libgazebo_ros_touch.so, else the size of
    the video texture (textvid's plugin, loaded here without ROS) on the display link."""
    from sim_world import plugins
    from sim_world.plugins.params import parse_params
    from simsensors.touch import TouchScreen
    from textvid.video import VideoPlugin
    spec = next((s for s in model.plugins if plugins.lookup(s.filename) is TouchScreen), None)
    if spec is None:
        return None
    label = 'plugin %s of model %s' % (spec.filename, model.name)
    p, _errors = parse_params(spec, TouchScreen.param_rows(), label, _NoWorld.log)
    body = p.bodyName or spec.link or model.root_link
    if p.bodyName is None and spec.link is None and 'mobile_display' in model.links:
        body = 'mobile_display'                     # as TouchScreen.setup picks it
    width, height, topic = p.displayWidth, p.displayHeight, None
    for vs in model.plugins:
        if plugins.lookup(vs.filename) is not VideoPlugin:
            continue
        video = VideoPlugin(vs, model, _NoWorld())
        try:
            video.load()
        except plugins.PluginError:
            continue
        size = video.texture_size(body)
        if size is not None:
            topic = video.image_topic
            width, height = width or size[0], height or size[1]
            break
    if width is None or height is None:
        # no video texture on the link: TouchScreen's default (square pixels, 512 on the
        # long side) is the texture a video plugin without size parameters would make
        from sim_world.model import PluginSpec
        spec0 = PluginSpec('libgazebo_ros_video.so', element=_element(body))
        video = VideoPlugin(spec0, model, _NoWorld())
        try:
            video.load()
        except plugins.PluginError:
            return None
        size = video.texture_size(body)
        width, height = width or size[0], height or size[1]
    return {'link': body, 'width': int(width), 'height': int(height), 'image_topic': topic}


def _element(body):
    import xml.etree.ElementTree as ET
    e = ET.Element('plugin')
    ET.SubElement(e, 'bodyName').text = body
    return e


def describe_world_file(path):
    """The models of a world file (sdf), described."""
    from sim_world.sdf import load_world_file
    return [describe_model(m) for m in load_world_file(path).models]


def describe_urdf(text, name):
    from sim_world.urdf import parse_urdf
    model = parse_urdf(text, name=name)
    if not model.robot_namespace:
        # spawned as the launch files spawn it: in the namespace of its own name (the
        # studio calls /<model>/inject_touch)
        model.robot_namespace = name
    return describe_model(model)
