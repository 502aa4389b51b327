"""Offscreen OpenGL rendering through OSMesa."""
