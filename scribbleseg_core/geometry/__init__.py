"""Geometry of triangle meshes: face measures, topology, Laplacians and the face (dual) graph."""
