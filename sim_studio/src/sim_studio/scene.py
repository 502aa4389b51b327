"""What the 3D view draws: each model's links and their visuals (boxes, cylinders, spheres,
planes; meshes and textured shapes as the renderer's own triangles, served by ``Assets``),
read with sim_world's own loaders (sdf.load_world_file for the world file, urdf.parse_urdf
for a spawned model's description), the link poses at the model's rest pose (its joints at
zero: the stream moves them to /gazebo/get_link_state's poses), and the phones' touch displays."""
import logging

import numpy as np

from sim_world.transforms import Pose

__all__ = ['Assets', 'describe_model', 'describe_world_file', 'describe_urdf', 'describe_sdf',
           'description_model', 'link_poses', 'display_of']


def _pose(p):
    return {'position': [float(v) for v in p.p], 'orientation': [float(v) for v in p.q]}


def _geometry(g, model=None, visual=None, assets=None):
    """What the page draws for a geometry: boxes, cylinders, spheres and planes as three.js
    primitives; a mesh, and a textured shape, as the renderer's own triangles (``shape``:
    the url the studio serves them at, and their bounding box as ``size`` and ``center``,
    drawn until they arrive)."""
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
    textured = visual is not None and visual.material.texture and g.kind != 'plane'
    if assets is not None and (g.kind == 'mesh' or textured):
        return assets.shape(g, model, visual, out)
    if g.kind == 'mesh':     # no assets to serve it from: a small box where it is
        out = {'kind': 'box', 'size': [0.05, 0.05, 0.05], 'mesh': g.filename}
    return out


class Assets(object):
    """The meshes and textures the page may fetch, by number: ``/shape/N`` (the
    renderer's triangles of a visual, ``sim_world.render.shapes.geometry_mesh``: the same
    mesh loader as the physics and the camera, so units, up axis, scale and winding are
    theirs) and ``/texture/N`` (a PNG). Nothing else on the disk is served."""

    def __init__(self):
        self.shapes = []          # [(Geometry, Model, visual)]
        self.textures = []        # [path or RGBA array]
        self._texture_ids = {}

    def shape(self, g, model, visual, out):
        from sim_world.render import shapes
        try:
            mesh = shapes.geometry_mesh(g, model.resolve_path if model is not None else None)
        except (shapes.MeshLoadError, ValueError) as e:
            print('studio: model %s: a visual is drawn as a small box: %s'
                  % (model.name if model is not None else '?', e), flush=True)
            return {'kind': 'box', 'size': [0.05, 0.05, 0.05], 'error': str(e)}
        lo, hi = mesh.bounds()
        self.shapes.append((g, model, visual))
        return dict(out, kind='shape', url='/shape/%d' % (len(self.shapes) - 1),
                    source=g.kind, size=[float(v) for v in (hi - lo)],
                    center=[float(v) for v in (hi + lo) / 2])

    def texture_url(self, key):
        """The url of a texture (a file path, or an image array of a mesh file)."""
        k = key if isinstance(key, str) else id(key)
        if k not in self._texture_ids:
            self._texture_ids[k] = len(self.textures)
            self.textures.append(key)
        return '/texture/%d' % self._texture_ids[k]

    def shape_bytes(self, n):
        """The binary of shape ``n``: a little-endian uint32 header length, the JSON header
        ({count, double, parts: [{first, count, rgba, texture}]}) padded to 4 bytes, then
        float32 positions (3 count), normals (3 count) and texture coordinates (2 count,
        t = 0 at the image's top). KeyError/IndexError for an unknown one."""
        import json
        import struct
        from sim_world.render import shapes
        g, model, visual = self.shapes[int(n)]
        mesh = shapes.geometry_mesh(g, model.resolve_path if model is not None else None)
        mat = visual.material if visual is not None else None
        rgba = [float(c) for c in np.asarray(mat.rgba, float)[:4]] if mat is not None \
            else [0.8, 0.8, 0.8, 1.0]
        parts = []
        if mat is not None and mat.texture:
            path = model.resolve_path(mat.texture) if model is not None else mat.texture
            parts = [{'first': 0, 'count': mesh.count, 'rgba': [1, 1, 1, rgba[3]],
                      'texture': self.texture_url(path)}]
        elif _file_materials(mat) and any(c is not None or img is not None
                                          for _f, _n, c, img in mesh.parts):
            for first, count, color, img in mesh.parts:
                parts.append({'first': int(first), 'count': int(count),
                              'rgba': [float(c) for c in color] if color is not None
                              and img is None else (rgba if img is None else [1, 1, 1, 1]),
                              'texture': self.texture_url(img) if img is not None else None})
        else:
            parts = [{'first': 0, 'count': mesh.count, 'rgba': rgba, 'texture': None}]
        head = json.dumps({'count': mesh.count, 'double': bool(mesh.double_sided),
                           'parts': parts}).encode()
        head += b' ' * (-len(head) % 4)
        return struct.pack('<I', len(head)) + head + b''.join(
            np.ascontiguousarray(a, '<f4').tobytes()
            for a in (mesh.positions, mesh.normals, mesh.uvs))

    def texture_png(self, n):
        """PNG bytes of texture ``n``; IndexError for an unknown one, ValueError for an
        unreadable file."""
        import cv2
        key = self.textures[int(n)]
        if isinstance(key, str):
            img = cv2.imread(key, cv2.IMREAD_UNCHANGED)
            if img is None:
                raise ValueError('cannot read the texture %s' % key)
        else:
            img = np.asarray(key, np.uint8)
            if img.ndim == 3 and img.shape[2] == 4:
                img = cv2.cvtColor(img, cv2.COLOR_RGBA2BGRA)
            elif img.ndim == 3:
                img = cv2.cvtColor(img, cv2.COLOR_RGB2BGR)
        ok, buf = cv2.imencode('.png', img)
        if not ok:
            raise ValueError('cannot encode texture %d' % int(n))
        return buf.tobytes()


def _file_materials(mat):
    """True when a visual names no material of its own, so the mesh file's colours apply
    (the renderer's rule)."""
    return mat is None or (mat.name is None and not mat.texture
                           and np.allclose(mat.rgba, (0.8, 0.8, 0.8, 1.0)))


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


def describe_model(model, assets=None):
    """{'name', 'static', 'links': [{'name', 'pose' (in the model frame), 'visuals'}]};
    meshes and textured shapes are registered in ``assets`` (without: small boxes)."""
    links = []
    for name, pose in link_poses(model).items():
        link = model.links.get(name)
        if link is None:
            continue
        visuals = []
        for v in link.visuals:
            rgba = [float(c) for c in np.asarray(v.material.rgba, float)[:4]]
            visuals.append({'geometry': _geometry(v.geometry, model, v, assets),
                            'origin': _pose(v.origin),
                            'rgba': rgba})
        links.append({'name': name, 'pose': _pose(pose), 'visuals': visuals})
    out = {'name': model.name, 'static': bool(model.static), 'links': links,
           'pose': _pose(model.pose),
           'articulated': any(j.movable for j in model.joints)}
    display = display_of(model)
    if display is not None:
        out['display'] = display
    cams = cameras_of(model)
    if cams:
        out['cameras'] = cams
    return out


def cameras_of(model):
    """The camera sensors of ``model``: [{'link' (the sensor looks along its +x, z up, as
    Gazebo's cameras do), 'hfov' (rad), 'width', 'height' (px)}]."""
    out = []
    for spec in model.plugins:
        if spec.sensor_type != 'camera' or spec.sensor is None or spec.link is None:
            continue

        def num(path, default):
            el = spec.sensor.find(path)
            try:
                return float(el.text) if el is not None and el.text else default
            except ValueError:
                return default
        out.append({'link': spec.link, 'hfov': num('camera/horizontal_fov', 1.047),
                    'width': int(num('camera/image/width', 320)),
                    'height': int(num('camera/image/height', 240))})
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


def describe_world_file(path, assets=None):
    """The models of a world file (sdf), described."""
    from sim_world.sdf import load_world_file
    return [describe_model(m, assets) for m in load_world_file(path).models]


def describe_urdf(text, name, assets=None, base_dir=None):
    from sim_world.urdf import parse_urdf
    model = parse_urdf(text, name=name, base_dir=base_dir)
    if not model.robot_namespace:
        # spawned as the launch files spawn it: in the namespace of its own name (the
        # studio calls /<model>/inject_touch)
        model.robot_namespace = name
    return describe_model(model, assets)


def describe_sdf(text, name, assets=None, base_dir=None):
    """An SDF <model> (what /gazebo/spawn_sdf_model took, or a world file's <model>) as
    model ``name``, read with the world's own loader (sim_world.sdf.parse_sdf_model)."""
    return describe_model(description_model('sdf', text, name, '', base_dir), assets)


def description_model(fmt, xml, name, robot_namespace='', base_dir=None):
    """The sim_world Model of a description as /gazebo/get_model_description answers it
    (``fmt`` 'urdf' or 'sdf'), read as the spawn services read it
    (sim_world.spawn.parse_description: in the spawn's namespace); ModelError/ValueError when
    it cannot be read."""
    from sim_world.spawn import parse_description
    return parse_description(fmt, xml, name, robot_namespace, base_dir or None)
