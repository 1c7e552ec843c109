"""Export labeled meshes in formats other tools read, atomically.

Every exporter takes the file's own vertices and faces (``Mesh.V_file``, ``Mesh.F_file``)
and one label per file face, ``-1`` meaning unlabeled:

- PLY (binary): per-face int ``label``, the same value as float ``quality`` (MeshLab shows
  per-face quality), and per-face RGBA colors.
- SEG: one label id per line (the PSB format).
- OBJ: one group per label (``g <label name>``), with a material per label (``.mtl``).
- GLB: one node and mesh per part, named by its label and colored by it.
- JSON sidecar: label names and colors, face counts, and a confidence summary per label.
- VTP (VTK XML poly data, for ParaView): cell data ``Label`` and, when given, ``Confidence``.

With a per-face confidence (:func:`~scribbleseg_core.engine.guidance.label_confidence`, in
[0, 1]), the PLY also has a float face property ``confidence``.
"""

from __future__ import annotations

import base64
import json
import os
import re
import struct
from collections.abc import Sequence
from pathlib import Path
from typing import Literal

import numpy as np

from scribbleseg_core.errors import ScribbleFileError, ScribblesegError
from scribbleseg_core.formats.labels import LabelSet
from scribbleseg_core.formats.seg import write_seg
from scribbleseg_core.infra.atomic import (
    atomic_write,
    atomic_write_bytes,
    atomic_write_text,
)

ExportFormat = Literal["ply", "seg", "obj", "glb", "json", "vtp"]
EXPORT_FORMATS: tuple[str, ...] = ("ply", "seg", "obj", "glb", "json", "vtp")
#: Faces below this confidence count as unconfident: in the JSON summary, and for the app's
#: "paint here next" (:func:`scribbleseg_core.engine.guidance.suggest`).
UNCONFIDENT = 0.5
UNLABELED_NAME = "unlabeled"


def check_labels(labels: np.ndarray, num_faces: int, num_labels: int, *, what: str = "labels") -> np.ndarray:
    """Validate per-face labels: shape (num_faces,), ints in [-1, num_labels).

    Returns
    -------
    labels : (m,) int64 ndarray

    Raises
    ------
    ScribblesegError
    """
    labels = np.asarray(labels)
    if labels.shape != (num_faces,):
        raise ScribblesegError(f"{what} must hold one value per face ({num_faces}); got shape {labels.shape}")
    if labels.size and not np.issubdtype(labels.dtype, np.integer):
        raise ScribblesegError(f"{what} must be integers; got {labels.dtype}")
    labels = labels.astype(np.int64)
    if labels.size and (labels.min() < -1 or labels.max() >= num_labels):
        raise ScribblesegError(
            f"{what} out of range: values span [{labels.min()}, {labels.max()}], "
            f"valid are -1 (unlabeled) to {num_labels - 1}"
        )
    return labels


def export_labeled_mesh(
    out_dir: str | os.PathLike,
    stem: str,
    V: np.ndarray,
    F: np.ndarray,
    labels: np.ndarray,
    label_set: LabelSet,
    formats: Sequence[str] = EXPORT_FORMATS,
    confidence: np.ndarray | None = None,
) -> list[Path]:
    """Write `labels` on mesh (V, F) in each of `formats` as ``out_dir/stem.<ext>``.

    Parameters
    ----------
    out_dir : str or os.PathLike
    stem : str
        File name without extension.
    V : (n, 3) float64 ndarray
    F : (m, 3) int64 ndarray
    labels : (m,) int ndarray
        Label id per face, -1 for unlabeled.
    label_set : LabelSet
    formats : sequence of {"ply", "seg", "obj", "glb", "json", "vtp"}
    confidence : (m,) float ndarray, optional
        Confidence per face in [0, 1]: written into the PLY, the VTP and the JSON summary.

    Returns
    -------
    list of Path
        The files written (the JSON sidecar is ``stem.labels.json``).
    """
    bad = [f for f in formats if f not in EXPORT_FORMATS]
    if bad:
        raise ValueError(f"unknown export format(s) {bad}; valid are {list(EXPORT_FORMATS)}")
    labels = check_labels(labels, len(F), len(label_set))
    if confidence is not None:
        confidence = check_confidence(confidence, len(F))
    out_dir = Path(out_dir)
    written = []
    for fmt in formats:
        if fmt == "ply":
            written.append(write_ply(out_dir / f"{stem}.ply", V, F, labels, label_set, confidence))
        elif fmt == "seg":
            written.append(write_seg(out_dir / f"{stem}.seg", labels))
        elif fmt == "obj":
            written.extend(write_obj(out_dir / f"{stem}.obj", V, F, labels, label_set))
        elif fmt == "glb":
            written.append(write_glb(out_dir / f"{stem}.glb", V, F, labels, label_set))
        elif fmt == "json":
            written.append(write_label_sidecar(out_dir / f"{stem}.labels.json", labels, label_set, mesh=stem,
                                               confidence=confidence))
        elif fmt == "vtp":
            written.append(write_vtp(out_dir / f"{stem}.vtp", V, F, labels, confidence))
    return written


def check_confidence(confidence: np.ndarray, num_faces: int) -> np.ndarray:
    """Validate a per-face confidence: shape (num_faces,), finite, in [0, 1]; (m,) float64."""
    confidence = np.asarray(confidence, dtype=np.float64)
    if confidence.shape != (num_faces,):
        raise ScribblesegError(f"confidence must hold one value per face ({num_faces}); got shape {confidence.shape}")
    if confidence.size and not (np.isfinite(confidence).all() and confidence.min() >= 0 and confidence.max() <= 1):
        raise ScribblesegError("confidence must lie in [0, 1]")
    return confidence


def _rgba_u8(label_set: LabelSet, labels: np.ndarray) -> np.ndarray:
    rgb = np.round(label_set.face_colors(labels) * 255).astype(np.uint8)
    return np.concatenate([rgb, np.full((len(rgb), 1), 255, np.uint8)], axis=1)


_PLY_FACE = np.dtype(
    [("n", "u1"), ("v", "<i4", (3,)), ("label", "<i4"), ("quality", "<f4"), ("rgba", "u1", (4,))]
)


def write_ply(path, V, F, labels, label_set: LabelSet, confidence: np.ndarray | None = None) -> Path:
    """Binary little-endian PLY with per-face ``label`` (int), ``quality`` (float), RGBA and,
    when given, ``confidence`` (float)."""
    V = np.asarray(V, dtype="<f8")
    F = np.asarray(F)
    names = " ".join(f"{i}={_token(n)}" for i, n in enumerate(label_set.names))
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        "comment scribbleseg labeled mesh; face label -1 = unlabeled\n"
        f"comment labels {names}\n"
        f"element vertex {len(V)}\nproperty double x\nproperty double y\nproperty double z\n"
        f"element face {len(F)}\nproperty list uchar int vertex_indices\n"
        "property int label\nproperty float quality\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n"
        + ("property float confidence\n" if confidence is not None else "")
        + "end_header\n"
    )
    dtype = _PLY_FACE if confidence is None else np.dtype(_PLY_FACE.descr + [("confidence", "<f4")])
    faces = np.empty(len(F), dtype=dtype)
    faces["n"] = 3
    faces["v"] = F
    faces["label"] = labels
    faces["quality"] = labels
    faces["rgba"] = _rgba_u8(label_set, labels)
    if confidence is not None:
        faces["confidence"] = confidence
    with atomic_write(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(V.tobytes())
        f.write(faces.tobytes())
    return Path(path)


def read_ply_labels(path: str | os.PathLike) -> np.ndarray:
    """Per-face ``label`` property of a PLY (ours or any PLY with an int face ``label``).

    Returns
    -------
    labels : (m,) int64 ndarray
    """
    import trimesh

    path = Path(path)
    try:
        mesh = trimesh.load(path, process=False)
        raw = mesh.metadata["_ply_raw"]["face"]["data"]
        return np.asarray(raw["label"], dtype=np.int64).reshape(-1)
    except FileNotFoundError:
        raise ScribbleFileError("file not found", path) from None
    except Exception as e:
        raise ScribbleFileError(f"no per-face 'label' property readable ({type(e).__name__})", path) from None


def _token(name: str) -> str:
    """A label name as one whitespace-free token (for OBJ group and material names)."""
    tok = re.sub(r"\s+", "_", name.strip())
    return tok or "label"


def write_obj(path, V, F, labels, label_set: LabelSet) -> list[Path]:
    """OBJ with one group (``g``) and one material (``usemtl``) per label, plus its ``.mtl``.

    Faces are written grouped by label (stable within a label), so their order in the
    OBJ differs from the source's; vertices keep their order, so a face is identified by
    its corner triple. Use PLY or SEG where face order must be kept.
    """
    path = Path(path)
    mtl_path = path.with_suffix(".mtl")
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    names = [_token(n) for n in label_set.names]
    order = np.argsort(labels, kind="stable")
    groups = np.split(order, np.flatnonzero(np.diff(labels[order])) + 1)
    with atomic_write(path, "w") as f:
        f.write(f"# scribbleseg labeled mesh: {len(V)} vertices, {len(F)} faces\n")
        f.write(f"mtllib {mtl_path.name}\n")
        np.savetxt(f, V, fmt="v %.9g %.9g %.9g")
        for grp in groups:
            if grp.size == 0:
                continue
            lab = int(labels[grp[0]])
            name = names[lab] if lab >= 0 else UNLABELED_NAME
            f.write(f"g {name}\nusemtl {name}\n")
            np.savetxt(f, F[grp] + 1, fmt="f %d %d %d")
    mtl = ["# scribbleseg label colors"]
    for lab, name in [(-1, UNLABELED_NAME), *enumerate(names)]:
        r, g, b = label_set.face_colors(np.array([lab]))[0]
        mtl.append(f"newmtl {name}\nKd {r:.4f} {g:.4f} {b:.4f}\nKa 0 0 0\nKs 0 0 0\nd 1")
    atomic_write_text(mtl_path, "\n".join(mtl) + "\n")
    return [path, mtl_path]


def read_obj_groups(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Faces and the group of each face in an OBJ (for checking OBJ exports).

    Returns
    -------
    F : (m, 3) int64 ndarray
        0-based vertex indices, in file order.
    group : (m,) int64 ndarray
        Index into `names` of each face's group (-1 before any ``g``).
    names : list of str
    """
    names: list[str] = []
    F, group, current = [], [], -1
    for line in Path(path).read_text(encoding="utf-8").splitlines():
        tok = line.split()
        if not tok:
            continue
        if tok[0] == "g":
            name = " ".join(tok[1:])
            if name not in names:
                names.append(name)
            current = names.index(name)
        elif tok[0] == "f":
            F.append([int(t.split("/")[0]) - 1 for t in tok[1:4]])
            group.append(current)
    return np.array(F, np.int64).reshape(-1, 3), np.array(group, np.int64), names


def write_glb(path, V, F, labels, label_set: LabelSet) -> Path:
    """Binary glTF with one node per part, named by its label, with the label's color."""
    import trimesh

    scene = trimesh.Scene()
    V = np.asarray(V, dtype=np.float64)
    for lab in np.unique(labels):
        sel = np.flatnonzero(labels == lab)
        name = label_set.names[lab] if lab >= 0 else UNLABELED_NAME
        used, Fi = np.unique(F[sel], return_inverse=True)
        part = trimesh.Trimesh(V[used], Fi.reshape(-1, 3), process=False)
        rgba = _rgba_u8(label_set, np.array([lab]))[0]
        part.visual = trimesh.visual.TextureVisuals(
            material=trimesh.visual.material.PBRMaterial(
                name=name, baseColorFactor=rgba, metallicFactor=0.0, roughnessFactor=0.8
            )
        )
        scene.add_geometry(part, geom_name=name, node_name=name)
    atomic_write_bytes(path, scene.export(file_type="glb"))
    return Path(path)


def write_label_sidecar(path, labels: np.ndarray, label_set: LabelSet, *, mesh: str,
                        confidence: np.ndarray | None = None) -> Path:
    """JSON with label names, colors and per-label face counts; with `confidence`, also
    ``"confidence"``: its mean, the faces below :data:`UNCONFIDENT`, and per label
    (``"-1"`` for unlabeled faces) the mean, the minimum and the unconfident faces."""
    counts = np.bincount(labels + 1, minlength=len(label_set) + 1)
    doc = {
        "format": "scribbleseg-labels",
        "version": 1,
        "mesh": mesh,
        "num_faces": int(len(labels)),
        "unlabeled": -1,
        **label_set.to_json(),
        "face_counts": {"-1": int(counts[0]), **{str(i): int(c) for i, c in enumerate(counts[1:])}},
    }
    if confidence is not None:
        doc["confidence"] = _confidence_summary(labels, confidence)
    atomic_write_text(path, json.dumps(doc, indent=1, separators=(",", ": ")) + "\n")
    return Path(path)


def _confidence_summary(labels: np.ndarray, confidence: np.ndarray) -> dict:
    def part(c: np.ndarray) -> dict:
        return {"mean": round(float(c.mean()), 4), "min": round(float(c.min()), 4),
                "unconfident_faces": int((c < UNCONFIDENT).sum())}

    return {"mean": round(float(confidence.mean()), 4) if confidence.size else None,
            "unconfident_below": UNCONFIDENT,
            "unconfident_faces": int((confidence < UNCONFIDENT).sum()),
            "per_label": {str(int(lab)): part(confidence[labels == lab]) for lab in np.unique(labels)}}


def write_vtp(path, V, F, labels: np.ndarray, confidence: np.ndarray | None = None) -> Path:
    """VTK XML poly data (``.vtp``, read by ParaView and VTK) with cell data ``Label``
    (Int32, -1 unlabeled) and, when given, ``Confidence`` (Float32); arrays inline, base64
    with a UInt64 byte-count header, little-endian."""
    V = np.asarray(V, dtype="<f8")
    F = np.asarray(F, dtype="<i8")
    cells = [_vtk_array("Label", np.asarray(labels, dtype="<i4"), "Int32")]
    if confidence is not None:
        cells.append(_vtk_array("Confidence", np.asarray(confidence, dtype="<f4"), "Float32"))
    doc = (
        '<?xml version="1.0"?>\n'
        '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">\n'
        "<PolyData>\n"
        f'<Piece NumberOfPoints="{len(V)}" NumberOfVerts="0" NumberOfLines="0" NumberOfStrips="0" '
        f'NumberOfPolys="{len(F)}">\n'
        f'<Points>\n{_vtk_array("Points", V, "Float64", components=3)}</Points>\n'
        "<Polys>\n"
        f'{_vtk_array("connectivity", F.reshape(-1), "Int64")}'
        f'{_vtk_array("offsets", np.arange(3, 3 * len(F) + 1, 3, dtype="<i8"), "Int64")}'
        "</Polys>\n"
        f'<CellData Scalars="Label">\n{"".join(cells)}</CellData>\n'
        "</Piece>\n</PolyData>\n</VTKFile>\n"
    )
    atomic_write_text(path, doc)
    return Path(path)


def _vtk_array(name: str, values: np.ndarray, vtk_type: str, components: int = 1) -> str:
    raw = np.ascontiguousarray(values).tobytes()
    data = base64.b64encode(struct.pack("<Q", len(raw)) + raw).decode("ascii")
    return (f'<DataArray type="{vtk_type}" Name="{name}" NumberOfComponents="{components}" '
            f'format="binary">{data}</DataArray>\n')


def read_vtp_cell_data(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """The cell data arrays of a ``.vtp`` written by :func:`write_vtp`, by name."""
    import xml.etree.ElementTree as ET

    types = {"Int32": "<i4", "Int64": "<i8", "Float32": "<f4", "Float64": "<f8"}
    try:
        root = ET.parse(path).getroot()
        out = {}
        for a in root.iter("CellData"):
            for d in a.iter("DataArray"):
                raw = base64.b64decode(d.text.strip())
                (n,) = struct.unpack("<Q", raw[:8])
                out[d.get("Name")] = np.frombuffer(raw[8:8 + n], dtype=types[d.get("type")]).copy()
        return out
    except (OSError, ET.ParseError, KeyError, ValueError, struct.error) as e:
        raise ScribbleFileError(f"not a readable VTP file ({type(e).__name__}: {e})", Path(path)) from None
