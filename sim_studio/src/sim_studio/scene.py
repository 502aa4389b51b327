"""What the 3D view draws: each model's links and their visuals (boxes, cylinders, spheres,
planes; a mesh is drawn as its bounding box in this first version), read with sim_world's
own loaders (sdf.load_world_file for the world file, urdf.parse_urdf for a spawned model's
description), and the link poses at the model's rest pose (its joints at zero)."""
import numpy as np

from sim_world.transforms import Pose

__all__ = ['describe_model', 'describe_world_file', 'describe_urdf', 'link_poses']


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
    return {'name': model.name, 'static': bool(model.static), 'links': links,
            'pose': _pose(model.pose)}


def describe_world_file(path):
    """The models of a world file (sdf), described."""
    from sim_world.sdf import load_world_file
    return [describe_model(m) for m in load_world_file(path).models]


def describe_urdf(text, name):
    from sim_world.urdf import parse_urdf
    return describe_model(parse_urdf(text, name=name))
