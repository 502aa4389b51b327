"""Mesh files the unit tests write (test_mesh.py, test_render.py)."""
import numpy as np


def write_dae(path, tris, unit=1.0, up='Z_UP', colour=None):
    """A Collada file at ``path`` of the triangles ``tris`` (n x 3 x 3) in units of ``unit``
    metres with ``up`` (Z_UP, Y_UP, X_UP) as up axis; ``colour``: an RGB diffuse material."""
    pos = ' '.join('%.6f' % c for c in np.asarray(tris).ravel())
    n = len(tris)
    idx = ' '.join(str(i) for i in range(3 * n))
    mat, bind, tri_mat = '', '', ''
    if colour is not None:
        mat = ('<library_effects><effect id="fx"><profile_COMMON><technique sid="c"><lambert>'
               '<diffuse><color>%g %g %g 1</color></diffuse></lambert></technique>'
               '</profile_COMMON></effect></library_effects><library_materials>'
               '<material id="m"><instance_effect url="#fx"/></material></library_materials>'
               % tuple(colour))
        bind = ('<bind_material><technique_common><instance_material symbol="s" target="#m"/>'
                '</technique_common></bind_material>')
        tri_mat = ' material="s"'
    doc = '''<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
 <asset><unit name="u" meter="%g"/><up_axis>%s</up_axis></asset>
 ''' % (unit, up) + mat + '''
 <library_geometries><geometry id="g" name="g"><mesh>
  <source id="p"><float_array id="pa" count="%d">%s</float_array>
   <technique_common><accessor source="#pa" count="%d" stride="3">
    <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
   </accessor></technique_common></source>
  <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
  <triangles count="%d"%s><input semantic="VERTEX" source="#v" offset="0"/><p>%s</p></triangles>
 </mesh></geometry></library_geometries>
 <library_visual_scenes><visual_scene id="s"><node id="n" name="n">
  <instance_geometry url="#g">%s</instance_geometry></node></visual_scene></library_visual_scenes>
 <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
''' % (9 * n, pos, 3 * n, n, tri_mat, idx, bind)
    with open(path, 'w') as f:
        f.write(doc)
