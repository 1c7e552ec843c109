"""Load meshes (OFF, OBJ, PLY, STL, GLB/GLTF), repair them, keep the file's face numbering.

:func:`load_mesh` returns a :class:`Mesh`: the repaired arrays used for processing plus
the maps between its faces and the faces of the file the user opened, so that scribbles,
labels and exports always refer to the file's own faces.
"""

from __future__ import annotations

import io
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from scribbleseg_core.errors import MeshLoadError
from scribbleseg_core.formats.obj import read_obj
from scribbleseg_core.formats.off import fan_triangulate, read_off
from scribbleseg_core.geometry.measures import face_areas, face_centroids, normalize
from scribbleseg_core.geometry.topology import boundary_loops, edges, face_components

MESH_EXTENSIONS = (".off", ".obj", ".ply", ".stl", ".glb", ".gltf")

#: Faces with area below this fraction of the mean face area are reported as tiny.
TINY_FACE_FRACTION = 1e-6


#: Largest coordinate magnitude accepted: areas and squared lengths (4th and 2nd powers of
#: coordinates) must stay finite in float64.
MAX_COORDINATE = 1e30


@dataclass(frozen=True)
class MeshReport:
    """What the loader found and repaired; what the paper's method would choke on.

    Counts refer to the file (``num_vertices``, ``num_faces``) or to the repaired mesh.
    """

    num_vertices: int
    num_faces: int
    merged_vertices: int
    dropped_degenerate_faces: int
    dropped_duplicate_faces: int
    nonmanifold_edges: int
    boundary_edges: int
    boundary_loops: int
    components: int
    zero_area_faces: int
    tiny_faces: int

    @property
    def is_closed_manifold(self) -> bool:
        return self.nonmanifold_edges == 0 and self.boundary_edges == 0

    def warnings(self) -> list[str]:
        """One line per issue worth a user's attention (empty for a clean mesh)."""
        out = []
        if self.merged_vertices:
            out.append(f"merged {self.merged_vertices} duplicate vertices")
        if self.dropped_degenerate_faces:
            out.append(f"dropped {self.dropped_degenerate_faces} degenerate faces (repeated corner)")
        if self.dropped_duplicate_faces:
            out.append(f"dropped {self.dropped_duplicate_faces} duplicate faces")
        if self.nonmanifold_edges:
            out.append(f"{self.nonmanifold_edges} non-manifold edges (processed anyway)")
        if self.boundary_loops:
            out.append(f"{self.boundary_loops} boundary loops ({self.boundary_edges} boundary edges)")
        if self.components > 1:
            out.append(f"{self.components} connected components")
        if self.tiny_faces:
            out.append(f"{self.tiny_faces} tiny faces ({self.zero_area_faces} of zero area)")
        return out

    def summary(self) -> str:
        head = f"{self.num_vertices} vertices, {self.num_faces} faces"
        w = self.warnings()
        return head + ("; " + "; ".join(w) if w else "; clean closed manifold")


@dataclass(frozen=True, eq=False)
class Mesh:
    """A loaded, repaired triangle mesh and its map to the file's faces.

    Attributes
    ----------
    V : (n, 3) float64 ndarray
        Repaired vertices in the file's units (duplicates merged, unused dropped).
    F : (m, 3) int64 ndarray
        Repaired faces (no degenerate or duplicate faces).
    V_file : (n0, 3) float64 ndarray
        Vertices as in the file.
    F_file : (m0, 3) int64 ndarray
        Faces as in the file (polygons fan-triangulated in file order). Face ids of
        scribbles, labels and exports index these.
    proc_to_file : (m,) int64 ndarray
        File face id of each repaired face.
    file_to_proc : (m0,) int64 ndarray
        Repaired face standing for each file face: itself, its kept twin (duplicates), or
        the nearest kept face (dropped degenerate faces).
    report : MeshReport
    path : Path or None
    """

    V: np.ndarray
    F: np.ndarray
    V_file: np.ndarray
    F_file: np.ndarray
    proc_to_file: np.ndarray
    file_to_proc: np.ndarray
    report: MeshReport
    path: Path | None = None
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def name(self) -> str:
        return self.path.stem if self.path else "mesh"

    @property
    def num_file_faces(self) -> int:
        return int(self.F_file.shape[0])

    def labels_to_file(self, labels: np.ndarray) -> np.ndarray:
        """Per-face values on the repaired mesh, (m, ...) -> per file face, (m0, ...)."""
        return np.asarray(labels)[self.file_to_proc]

    def faces_to_file(self, faces: np.ndarray) -> np.ndarray:
        """The file faces of repaired faces `faces` (a dropped duplicate or degenerate file face
        goes with the face that took its label), sorted (k,) int64."""
        chosen = np.zeros(self.F.shape[0], bool)
        chosen[np.asarray(faces, dtype=np.int64)] = True
        return np.flatnonzero(self.labels_to_file(chosen)).astype(np.int64)

    def labels_from_file(self, labels: np.ndarray) -> np.ndarray:
        """Per file face values, (m0, ...) -> per repaired face, (m, ...)."""
        return np.asarray(labels)[self.proc_to_file]

    def normalized(self) -> np.ndarray:
        """Repaired vertices centered and scaled to unit area, (n, 3) float64 (cached)."""
        if "V_unit" not in self._cache:
            self._cache["V_unit"] = normalize(self.V, self.F)[0]
        return self._cache["V_unit"]


def load_mesh(path: str | os.PathLike) -> Mesh:
    """Load, validate and repair a triangle mesh.

    Parameters
    ----------
    path : str or os.PathLike
        An .off, .obj, .ply, .stl, .glb or .gltf file. Polygons are fan-triangulated.

    Returns
    -------
    Mesh

    Raises
    ------
    MeshLoadError
        Missing file, unknown extension, empty, truncated or garbage content, NaN or
        infinite coordinates, face indices out of range, or no triangles at all.
    """
    path = Path(path)
    V, F = read_triangles(path)
    return repair(V, F, path=path)


def read_triangles(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """Read a mesh file's vertices and (triangulated) faces, validated, unrepaired.

    Returns
    -------
    V : (n0, 3) float64 ndarray
    F : (m0, 3) int64 ndarray
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in MESH_EXTENSIONS:
        raise MeshLoadError(
            f"unknown mesh extension {path.suffix!r}; expected one of {', '.join(MESH_EXTENSIONS)}", path
        )
    if not path.exists():
        raise MeshLoadError("file not found", path)
    if path.is_dir():
        raise MeshLoadError("is a folder, not a mesh file", path)
    try:
        data = path.read_bytes()
    except OSError as e:
        raise MeshLoadError(f"cannot read: {e.strerror}", path) from None
    if not data.strip():
        raise MeshLoadError("empty file", path)
    if ext == ".off":
        V, faces = read_off(data, path)
        F = fan_triangulate(faces)
    elif ext == ".obj":
        V, F = read_obj(data, path)
    else:
        if ext == ".ply":
            _check_ascii_ply_complete(data, path)
        V, F = _read_with_trimesh(data, ext, path)
    _validate(V, F, path)
    return V, F


def _read_with_trimesh(data: bytes, ext: str, path: Path) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    if ext == ".gltf" and b'"uri"' in data and b"data:" not in data:
        resolver = trimesh.resolvers.FilePathResolver(path.parent)
    else:
        resolver = None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            loaded = trimesh.load(
                io.BytesIO(data), file_type=ext[1:], process=False, resolver=resolver
            )
    except Exception as e:  # trimesh raises anything on garbage; we report one thing
        raise MeshLoadError(f"unreadable or corrupt {ext[1:].upper()} file ({type(e).__name__}: {e})"[:300], path) from None
    return _triangles_of(loaded, path)


def _check_ascii_ply_complete(data: bytes, path: Path) -> None:
    """Refuse an ASCII PLY with fewer data lines than its elements announce.

    trimesh reads a truncated ASCII PLY without complaint; binary PLY is size-checked there.
    """
    end = data.find(b"end_header")
    if end < 0 or b"format ascii" not in data[:end]:
        return
    announced = 0
    for line in data[:end].splitlines():
        tok = line.split()
        if len(tok) == 3 and tok[0] == b"element" and tok[2].isdigit():
            announced += int(tok[2])
    body = data[end:].split(b"\n", 1)[-1]
    present = sum(1 for line in body.splitlines() if line.strip())
    if present < announced:
        raise MeshLoadError(
            f"truncated: the header announces {announced} element lines, the file holds {present}", path
        )


def _triangles_of(loaded, path: Path) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    if isinstance(loaded, trimesh.Scene):
        meshes = [g for g in loaded.dump(concatenate=False) if isinstance(g, trimesh.Trimesh)]
        meshes = [g for g in meshes if len(g.faces)]
        if not meshes:
            raise MeshLoadError("the scene holds no triangles", path)
        Vs, Fs, offset = [], [], 0
        for g in meshes:
            Vs.append(np.asarray(g.vertices, dtype=np.float64))
            Fs.append(np.asarray(g.faces, dtype=np.int64) + offset)
            offset += len(g.vertices)
        return np.concatenate(Vs), np.concatenate(Fs)
    if not isinstance(loaded, trimesh.Trimesh):
        raise MeshLoadError(f"holds no triangles (a {type(loaded).__name__})", path)
    return np.asarray(loaded.vertices, dtype=np.float64), np.asarray(loaded.faces, dtype=np.int64)


def _validate(V: np.ndarray, F: np.ndarray, path) -> None:
    if V.ndim != 2 or V.shape[1] != 3 or V.shape[0] == 0:
        raise MeshLoadError(f"no vertices (vertex array of shape {V.shape})", path)
    if F.ndim != 2 or F.shape[1] != 3 or F.shape[0] == 0:
        raise MeshLoadError("empty mesh: no triangles", path)
    if not np.isfinite(V).all():
        bad = int(np.flatnonzero(~np.isfinite(V).all(axis=1))[0])
        raise MeshLoadError(f"vertex {bad} has a NaN or infinite coordinate", path)
    too_large = np.abs(V).max(axis=1) > MAX_COORDINATE
    if too_large.any():
        bad = int(np.flatnonzero(too_large)[0])
        raise MeshLoadError(f"vertex {bad} has a coordinate too large to process ({np.abs(V[bad]).max():.3g}; "
                            f"at most {MAX_COORDINATE:.0e} in magnitude)", path)
    if F.min() < 0 or F.max() >= V.shape[0]:
        raise MeshLoadError(
            f"face index out of range: indices span [{F.min()}, {F.max()}], "
            f"the mesh has {V.shape[0]} vertices",
            path,
        )


def repair(V: np.ndarray, F: np.ndarray, *, path: str | os.PathLike | None = None) -> Mesh:
    """Merge duplicate vertices, drop degenerate and duplicate faces, keep the face map.

    Parameters
    ----------
    V : (n0, 3) float64 ndarray
    F : (m0, 3) int64 ndarray
    path : str or os.PathLike, optional
        The source file, for messages and naming.

    Returns
    -------
    Mesh
    """
    path = None if path is None else Path(path)
    V = np.ascontiguousarray(V, dtype=np.float64)
    F = np.ascontiguousarray(F, dtype=np.int64)
    _validate(V, F, path)
    # 1. merge vertices equal up to a tiny fraction of the bounding-box diagonal
    diag = float(np.linalg.norm(V.max(0) - V.min(0))) or 1.0
    key = np.round(V / (diag * 1e-9)).astype(np.int64)
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inv = inv.ravel()
    Fm = inv[F]
    # 2. degenerate faces: a repeated corner after merging
    degenerate = (Fm[:, 0] == Fm[:, 1]) | (Fm[:, 1] == Fm[:, 2]) | (Fm[:, 0] == Fm[:, 2])
    # 3. duplicate faces: same corner set (either orientation); keep the first
    sorted_faces = np.sort(Fm, axis=1)
    sorted_faces[degenerate] = -1 - np.arange(degenerate.sum())[:, None]  # never a duplicate
    _, first_face, twin = np.unique(sorted_faces, axis=0, return_index=True, return_inverse=True)
    twin = first_face[twin.ravel()]
    keep = ~degenerate & (twin == np.arange(F.shape[0]))
    if not keep.any():
        raise MeshLoadError("no valid triangles: every face is degenerate", path)
    proc_to_file = np.flatnonzero(keep).astype(np.int64)
    file_to_proc = np.full(F.shape[0], -1, np.int64)
    file_to_proc[proc_to_file] = np.arange(proc_to_file.size)
    dup = ~degenerate & ~keep
    file_to_proc[dup] = file_to_proc[twin[dup]]
    # 4. compact vertices
    Fk = Fm[keep]
    used, Fc = np.unique(Fk, return_inverse=True)
    Fc = Fc.reshape(-1, 3).astype(np.int64)
    Vc = V[first[used]]
    if degenerate.any():  # stand-in: nearest kept face by centroid
        tree = cKDTree(face_centroids(Vc, Fc))
        file_to_proc[degenerate] = tree.query(face_centroids(V, F[degenerate]))[1]
    report = _report(V, F, Vc, Fc, degenerate, dup)
    return Mesh(Vc, Fc, V, F, proc_to_file, file_to_proc, report, path)


def _report(V0, F0, V, F, degenerate, dup) -> MeshReport:
    ed = edges(F)
    A = face_areas(V, F)
    mean_area = A.mean() if A.size else 0.0
    return MeshReport(
        num_vertices=int(V0.shape[0]),
        num_faces=int(F0.shape[0]),
        merged_vertices=int(np.unique(F0).size - V.shape[0]),
        dropped_degenerate_faces=int(degenerate.sum()),
        dropped_duplicate_faces=int(dup.sum()),
        nonmanifold_edges=int((ed.count > 2).sum()),
        boundary_edges=int((ed.count == 1).sum()),
        boundary_loops=boundary_loops(F, ed),
        components=face_components(F, ed)[0],
        zero_area_faces=int((A <= 0).sum()),
        tiny_faces=int((A < TINY_FACE_FRACTION * mean_area).sum()),
    )


def find_meshes(folder: str | os.PathLike) -> list[Path]:
    """Mesh files directly inside `folder`, sorted naturally (2.off before 10.off)."""
    folder = Path(folder)
    files = [p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in MESH_EXTENSIONS]
    return sorted(files, key=natural_key)


def natural_key(path: Path) -> tuple:
    """Sort key ordering numeric stems numerically: ``1, 2, 10`` rather than ``1, 10, 2``."""
    stem = path.stem
    return (0, int(stem), "") if stem.isdigit() else (1, 0, stem)
