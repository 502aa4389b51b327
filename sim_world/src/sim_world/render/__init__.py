"""Offscreen OpenGL rendering through OSMesa (Mesa llvmpipe; no X server, no GPU).

::

    from sim_world.render import get_context, Renderer, CameraView
    r = Renderer()
    r.add_model(model)
    r.set_link_poses(model.name, {link: Pose, ...})
    rgb, depth = r.render(CameraView(480, 800, hfov, pose), depth=True)

See ``context`` (the one context of the process, FBO targets, readback), ``shapes``
(primitive and mesh triangles with normals) and ``renderer`` (the scene and cameras).
"""
from .context import get_context, Context, RenderError, linearize_depth  # noqa: F401
from .renderer import Renderer, CameraView, EYE_FROM_LINK  # noqa: F401
from .shapes import MeshLoadError, BOX_FACES  # noqa: F401

__all__ = ['get_context', 'Context', 'RenderError', 'Renderer', 'CameraView', 'MeshLoadError',
           'BOX_FACES', 'linearize_depth', 'EYE_FROM_LINK']
