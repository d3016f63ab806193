"""Regenerates rounded_punch.msh (Gmsh 4.15 Python API: `pip install gmsh`).

A punch with a flat 0.6 mm wide and rounded edges of radius R = 0.3 mm, 1.2 mm wide and
0.6 mm tall, its flat at y = 0. Quadrangles (recombined), 20 um along the rounded bottom
(`transfinite` curves), growing to 80 um at the top. Physical groups: curves 'bottom' (the
flat and both roundings), 'flat', 'top' (y = 0.6), 'sides'; point 'top_left'; surface 'punch'.
MSH 4.1 ASCII. Usage: `python3 rounded_punch.py [out.msh] [element size along the bottom]`.
"""
import sys
import gmsh

FLAT, R, H = 0.6, 0.3, 0.6
H_FINE, H_TOP = 0.02, 0.08
out = sys.argv[1] if len(sys.argv) > 1 else "rounded_punch.msh"
h_fine = float(sys.argv[2]) if len(sys.argv) > 2 else H_FINE
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.model.add("rounded_punch")
geo = gmsh.model.geo
a = FLAT / 2
p_flat_l = geo.addPoint(-a, 0, 0, h_fine)
p_flat_r = geo.addPoint(a, 0, 0, h_fine)
c_r = geo.addPoint(a, R, 0, h_fine)
c_l = geo.addPoint(-a, R, 0, h_fine)
p_side_r = geo.addPoint(a + R, R, 0, h_fine)
p_side_l = geo.addPoint(-a - R, R, 0, h_fine)
p_top_r = geo.addPoint(a + R, H, 0, H_TOP)
p_top_l = geo.addPoint(-a - R, H, 0, H_TOP)
flat = geo.addLine(p_flat_l, p_flat_r)
arc_r = geo.addCircleArc(p_flat_r, c_r, p_side_r)
side_r = geo.addLine(p_side_r, p_top_r)
top = geo.addLine(p_top_r, p_top_l)
side_l = geo.addLine(p_top_l, p_side_l)
arc_l = geo.addCircleArc(p_side_l, c_l, p_flat_l)
loop = geo.addCurveLoop([flat, arc_r, side_r, top, side_l, arc_l])
surface = geo.addPlaneSurface([loop])
geo.synchronize()
n_flat = round(FLAT / h_fine)
n_arc = round(3.141592653589793 * R / 2 / h_fine)
gmsh.model.mesh.setTransfiniteCurve(flat, n_flat + 1)
gmsh.model.mesh.setTransfiniteCurve(arc_r, n_arc + 1)
gmsh.model.mesh.setTransfiniteCurve(arc_l, n_arc + 1)
gmsh.model.addPhysicalGroup(1, [arc_l, flat, arc_r], name="bottom")
gmsh.model.addPhysicalGroup(1, [top], name="top")
gmsh.model.addPhysicalGroup(1, [flat], name="flat")
gmsh.model.addPhysicalGroup(1, [side_l, side_r], name="sides")
gmsh.model.addPhysicalGroup(2, [surface], name="punch")
gmsh.model.addPhysicalGroup(0, [p_top_l], name="top_left")
gmsh.option.setNumber("Mesh.RecombineAll", 1)
gmsh.option.setNumber("Mesh.Algorithm", 8)
gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
gmsh.model.mesh.generate(2)
gmsh.write(out)
gmsh.finalize()
