"""scribbleseg core: scribble-based segmentation of 3D shape collections.

A GUI-free library (it never imports Qt, polyscope or ``app``). Functions take and
return plain arrays. Array shapes are written with these named dimensions:

n
    vertices of a mesh
m
    faces (triangles) of a mesh
p
    primitive patches of a mesh
k
    labels (parts)
d
    feature dimensions

``V (n, 3) float64`` are vertex positions, ``F (m, 3) int64`` triangle vertex indices.
Face ids everywhere (scribbles, labels, exports) are those of the triangulated file the
user opened; see :class:`scribbleseg_core.formats.mesh.Mesh` for the map to the repaired
mesh used for processing.
"""

from scribbleseg_core.errors import (
    MeshLoadError,
    ModelFileError,
    ScribbleFileError,
    ScribblesegError,
    SessionFileError,
)

__version__ = "0.2.0"

__all__ = [
    "MeshLoadError",
    "ModelFileError",
    "ScribbleFileError",
    "ScribblesegError",
    "SessionFileError",
    "__version__",
]
