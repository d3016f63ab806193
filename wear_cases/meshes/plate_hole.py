"""Regenerates plate_hole.msh (Gmsh 4.15 Python API: `pip install gmsh`).

Quarter of a square plate (half-width 10 mm) with a central circular hole (radius 1 mm),
meshed with quadrangles (recombined), refined at the hole. Physical groups:
curves 'left' (x = 0), 'bottom' (y = 0), 'right' (x = 10), 'top' (y = 10), 'hole';
surface 'plate'. Written as MSH 4.1 ASCII.
"""
import gmsh

R, W = 1.0, 10.0
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.model.add("plate_hole")
occ = gmsh.model.occ
plate = occ.addRectangle(0, 0, 0, W, W)
hole = occ.addDisk(0, 0, 0, R, R)
occ.cut([(2, plate)], [(2, hole)])
occ.synchronize()
curves = {}
for dim, tag in gmsh.model.getEntities(1):
    x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(dim, tag)
    if abs(x0) < 1e-5 and abs(x1) < 1e-5:
        curves.setdefault("left", []).append(tag)
    elif abs(y0) < 1e-5 and abs(y1) < 1e-5:
        curves.setdefault("bottom", []).append(tag)
    elif abs(x0 - W) < 1e-5 and abs(x1 - W) < 1e-5:
        curves.setdefault("right", []).append(tag)
    elif abs(y0 - W) < 1e-5 and abs(y1 - W) < 1e-5:
        curves.setdefault("top", []).append(tag)
    else:
        curves.setdefault("hole", []).append(tag)
for name, tags in curves.items():
    gmsh.model.addPhysicalGroup(1, tags, name=name)
surf = [t for _, t in gmsh.model.getEntities(2)]
gmsh.model.addPhysicalGroup(2, surf, name="plate")
# Size field: 0.04 mm at the hole growing to 1 mm far away.
f = gmsh.model.mesh.field
d = f.add("Distance")
f.setNumbers(d, "CurvesList", curves["hole"])
f.setNumber(d, "Sampling", 200)
th = f.add("Threshold")
f.setNumber(th, "InField", d)
f.setNumber(th, "SizeMin", 0.05)
f.setNumber(th, "SizeMax", 1.0)
f.setNumber(th, "DistMin", 0.0)
f.setNumber(th, "DistMax", 6.0)
f.setAsBackgroundMesh(th)
gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
gmsh.option.setNumber("Mesh.RecombineAll", 1)
gmsh.option.setNumber("Mesh.Algorithm", 8)
gmsh.model.mesh.generate(2)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
gmsh.option.setNumber("Mesh.Binary", 0)
gmsh.write("plate_hole.msh")
gmsh.finalize()
