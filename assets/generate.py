"""Generate the bundled demo collections (deterministic): ``python assets/generate.py [OUT]``.

Two families in the PSB layout, so every tool reads them as it reads ``../shared/psb``:

    assets/<Family>/<name>.ply                 mesh (binary PLY, float32 coordinates)
    assets/<Family>/labels/<name>.seg          ground-truth label per face
    assets/<Family>/labels/label_names.txt     "<id> <name>" per line
    assets/<Family>/scribbles/<name>.json      example scribbles (format v1), a few shapes

Each shape is a boolean union of primitives (manifold3d), so the parts meet at real
concave creases; the union is remeshed isotropically (pymeshlab), which keeps it watertight
and manifold with well-shaped triangles, and every face takes the part of the nearest face
of the densely subdivided union. Scribbles follow the PSB protocol: one stroke per connected
part, a one-face-wide path along the part's principal axis, less a tenth at each end.

Needs the ``assets`` extra (manifold3d, pymeshlab).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
FACES_TARGET = 8000  # per shape; isotropic edge length is derived from the surface area


# ----------------------------------------------------------------------------- parts


def _quadruped(rng: np.random.Generator):
    import manifold3d as m3

    L, W, H = rng.uniform(1.3, 2.0), rng.uniform(0.5, 0.8), rng.uniform(0.45, 0.7)
    body = m3.Manifold.sphere(1.0, 96).scale((L, W, H))
    r_head = rng.uniform(0.32, 0.5)
    head = (m3.Manifold.sphere(1.0, 64).scale((1.35 * r_head, r_head, r_head))
            .translate((L * 0.9 + 0.2 * r_head, 0, H * rng.uniform(0.5, 0.9))))
    r_leg, len_leg = rng.uniform(0.1, 0.17), rng.uniform(0.8, 1.5)
    swing = rng.uniform(0, 25)
    legs = []
    for sx, sy, phase in [(1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)]:
        leg = m3.Manifold.cylinder(len_leg, 0.8 * r_leg, r_leg, 40).translate((0, 0, -len_leg))
        leg = leg.rotate((0, phase * swing, 0)).translate((sx * 0.62 * L, sy * 0.55 * W, -0.35 * H))
        legs.append(leg)
    len_tail = rng.uniform(0.6, 1.2)
    tail = (m3.Manifold.cylinder(len_tail, 0.09, 0.04, 24).rotate((0, -90 + rng.uniform(20, 60), 0))
            .translate((-0.9 * L, 0, 0.2 * H)))
    # parts: body, head, leg, tail
    return ["body", "head", "leg", "tail"], [[body], [head], legs, [tail]]


def _chair(rng: np.random.Generator):
    import manifold3d as m3

    w, d, t = rng.uniform(0.9, 1.3), rng.uniform(0.85, 1.2), rng.uniform(0.12, 0.18)
    h = rng.uniform(0.8, 1.1)
    seat = m3.Manifold.cube((w, d, t), center=True).translate((0, 0, h))
    hb, tb, tilt = rng.uniform(0.8, 1.3), rng.uniform(0.11, 0.16), rng.uniform(0, 20)
    # no part shares a plane with another (coplanar boolean faces leave slivers)
    back = (m3.Manifold.cube((0.94 * w, tb, hb), center=True).translate((0, 0, hb / 2))
            .rotate((-tilt, 0, 0)).translate((0, -d / 2 + tb / 2, h + t / 2 - 0.02)))
    s = rng.uniform(0.09, 0.13)
    round_legs = rng.random() < 0.5
    splay = rng.uniform(0, 8)
    legs = []
    for sx, sy in [(1, 1), (1, -1), (-1, 1), (-1, -1)]:
        # built hanging from the seat (top at z = 0), splayed about its top, then placed
        if round_legs:
            leg = m3.Manifold.cylinder(h, s * 0.6, s * 0.7, 32).translate((0, 0, -h))
        else:
            leg = m3.Manifold.cube((s, s, h)).translate((-s / 2, -s / 2, -h))
        leg = leg.rotate((-sy * splay, sx * splay, 0)).translate((sx * (w / 2 - s), sy * (d / 2 - s), h))
        legs.append(leg)
    names, parts = ["seat", "back", "leg", "arm"], [[seat], [back], legs, []]
    if rng.random() < 0.6:
        ha, ta = rng.uniform(0.25, 0.4), rng.uniform(0.1, 0.14)
        for sx in (1, -1):
            x = sx * (w / 2 + 0.2 * ta)  # overhangs the seat's side a little
            rest = m3.Manifold.cube((ta, d * 0.85, ta), center=True).translate((x, 0, h + t / 2 + ha))
            post = m3.Manifold.cube((0.7 * ta, 0.7 * ta, ha), center=True).translate((x, d * 0.3, h + t / 2 + ha / 2))
            parts[3] += [rest, post]
    return names, parts


FAMILIES = {"Quadruped": (_quadruped, 10, (0, 3, 6)), "Chair": (_chair, 10, (0, 4, 7))}


# ----------------------------------------------------------------------------- meshing


def _union_with_labels(parts: list[list]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    import manifold3d as m3

    tagged, label_of_id = [], {}
    for label, group in enumerate(parts):
        for p in group:
            q = p.as_original()
            label_of_id[q.original_id()] = label
            tagged.append(q)
    union = m3.Manifold.batch_boolean(tagged, m3.OpType.Add)
    mesh = union.to_mesh()
    V = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
    F = np.asarray(mesh.tri_verts, dtype=np.int64)
    labels = np.empty(len(F), np.int64)
    run_index = np.asarray(mesh.run_index) // 3
    for r, oid in enumerate(np.asarray(mesh.run_original_id)):
        labels[run_index[r] : run_index[r + 1]] = label_of_id[int(oid)]
    return V, F, labels


def _remesh(V, F, target_faces: int) -> tuple[np.ndarray, np.ndarray]:
    import pymeshlab

    area = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum()
    edge = float(np.sqrt(4 * area / (np.sqrt(3) * target_faces)))
    # Sharp features are kept (feature angle 35°) unless that leaves slivers at the
    # boolean seams; then other settings are tried and the best-shaped result kept.
    best = None
    for iterations, feature in ((8, 35), (12, 35), (10, 60), (10, 90), (12, 180)):
        ms = pymeshlab.MeshSet()
        ms.add_mesh(pymeshlab.Mesh(V, F.astype(np.int32)))
        ms.meshing_isotropic_explicit_remeshing(targetlen=pymeshlab.PureValue(edge), iterations=iterations, featuredeg=feature)
        m = ms.current_mesh()
        Vr, Fr = m.vertex_matrix().astype(np.float64), m.face_matrix().astype(np.int64)
        quality = (_slivers(Vr, Fr), -_min_angle(Vr, Fr))
        if best is None or quality < best[0]:
            best = (quality, Vr, Fr)
        if quality[0] == 0:
            break
    return best[1], best[2]


def _slivers(V, F, degrees: float = 5.0) -> int:
    """Faces with a corner under `degrees`."""
    from scribbleseg_core.signatures.curvature import corner_angles

    return int((np.degrees(corner_angles(V, F).min(axis=1)) < degrees).sum())


def _min_angle(V, F) -> float:
    """Smallest corner angle in degrees."""
    from scribbleseg_core.signatures.curvature import corner_angles

    return float(np.degrees(corner_angles(V, F).min()))


def _transfer_labels(Vs, Fs, ls, V, F) -> np.ndarray:
    """Label of the source triangle closest to each target face centroid."""
    import trimesh

    src = trimesh.Trimesh(Vs, Fs, process=False)
    _, _, tri = trimesh.proximity.closest_point(src, V[F].mean(axis=1))
    return ls[tri]


def make_shape(family: str, index: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """One demo shape: V (n, 3) float32-exact float64, F (m, 3), labels (m,), label names."""
    build = FAMILIES[family][0]
    rng = np.random.default_rng([hash_family(family), index])
    names, parts = build(rng)
    V0, F0, l0 = _union_with_labels(parts)
    V, F = _remesh(V0, F0, FACES_TARGET)
    V = V.astype(np.float32).astype(np.float64)  # what the file stores
    return V, F, _transfer_labels(V0, F0, l0, V, F), names


def hash_family(family: str) -> int:
    return sum((i + 1) * ord(c) for i, c in enumerate(family))


# ----------------------------------------------------------------------------- scribbles


def psb_protocol_strokes(V, F, labels, min_fraction: float = 0.005) -> list[tuple[int, np.ndarray]]:
    """One stroke per connected part that is its label's largest or covers >= 0.5% of the area."""
    from scipy.sparse.csgraph import connected_components, dijkstra

    from scribbleseg_core.geometry.dual_graph import dual_graph
    from scribbleseg_core.geometry.measures import face_areas

    g = dual_graph(V, F)
    same = labels[g.pairs[:, 0]] == labels[g.pairs[:, 1]]
    G = g.matrix(same.astype(float))
    G.eliminate_zeros()
    _, comp = connected_components(G, directed=False)
    A = face_areas(V, F)
    C = V[F].mean(axis=1)
    parts = np.unique(comp)
    part_area = np.bincount(comp, A)
    part_label = np.array([labels[np.flatnonzero(comp == c)[0]] for c in parts])
    strokes = []
    W = g.matrix(np.where(same, g.centroid_dist, 0.0))
    W.eliminate_zeros()
    for c in parts:
        lab = part_label[c]
        largest = part_area[c] == part_area[part_label == lab].max()
        if not (largest or part_area[c] >= min_fraction * A.sum()):
            continue
        ids = np.flatnonzero(comp == c)
        X = C[ids] - C[ids].mean(0)
        axis = np.linalg.svd(X, full_matrices=False)[2][0]
        proj = X @ axis
        lo, hi = np.quantile(proj, [0.1, 0.9])
        a = ids[np.argmin(np.abs(proj - lo))]
        b = ids[np.argmin(np.abs(proj - hi))]
        _, pred = dijkstra(W, directed=False, indices=a, return_predecessors=True)
        path = [b]
        while path[-1] != a and pred[path[-1]] >= 0:
            path.append(pred[path[-1]])
        strokes.append((int(lab), np.array(path[::-1], dtype=np.int64)))
    return strokes


# ----------------------------------------------------------------------------- files


def write_ply_f32(path: Path, V: np.ndarray, F: np.ndarray) -> None:
    header = (f"ply\nformat binary_little_endian 1.0\ncomment scribbleseg demo shape\n"
              f"element vertex {len(V)}\nproperty float x\nproperty float y\nproperty float z\n"
              f"element face {len(F)}\nproperty list uchar int vertex_indices\nend_header\n")
    faces = np.empty(len(F), dtype=[("n", "u1"), ("v", "<i4", (3,))])
    faces["n"], faces["v"] = 3, F
    path.write_bytes(header.encode() + V.astype("<f4").tobytes() + faces.tobytes())


def generate(out: Path = HERE, families=None, only: int | None = None) -> None:
    """Write every family (or `families`, or only shape index `only`) under `out`."""
    from scribbleseg_core.formats.scribbles import Scribbles, Stroke, write_scribbles
    from scribbleseg_core.formats.seg import write_seg

    for family in families or FAMILIES:
        _, count, scribbled = FAMILIES[family]
        folder = out / family
        (folder / "labels").mkdir(parents=True, exist_ok=True)
        (folder / "scribbles").mkdir(exist_ok=True)
        for i in range(count) if only is None else [only]:
            V, F, labels, names = make_shape(family, i)
            name = f"{family.lower()}_{i + 1:02d}"
            write_ply_f32(folder / f"{name}.ply", V, F)
            write_seg(folder / "labels" / f"{name}.seg", labels)
            if i in scribbled:
                strokes = tuple(Stroke(lab, faces) for lab, faces in psb_protocol_strokes(V, F, labels))
                write_scribbles(folder / "scribbles" / f"{name}.json",
                                Scribbles(f"{name}.ply", len(F), tuple(names), strokes))
            print(f"{family}/{name}: {len(F)} faces, parts {np.bincount(labels, minlength=len(names)).tolist()}", flush=True)
        (folder / "labels" / "label_names.txt").write_text("".join(f"{j} {n}\n" for j, n in enumerate(names)))


if __name__ == "__main__":
    generate(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE)
