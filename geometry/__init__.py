"""Geometry: meshes in, tetrahedra, physical and boundary particles, cutting, surfaces, export.

Implements the paper's Sect. 5.1 (physical particles from a Delaunay tetrahedralization),
Sect. 5.2 (fracture surfaces, adaptive subdivision) and Sect. 5.3 (boundary particles).
"""
