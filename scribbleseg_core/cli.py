"""The ``scribbleseg`` command line.

Every bad input ends as one line ``error: <file>: <problem>`` and exit status 2, never a
traceback.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from scribbleseg_core import __version__
from scribbleseg_core.engine.optimize import METHODS
from scribbleseg_core.errors import ScribblesegError
from scribbleseg_core.formats.mesh import MESH_EXTENSIONS


def _cmd_info(args) -> int:
    from scribbleseg_core.formats.mesh import load_mesh
    from scribbleseg_core.formats.scribbles import read_scribbles

    status = 0
    for p in args.files:
        try:
            if Path(p).suffix.lower() == ".json":
                scr = read_scribbles(p)
                n = sum(len(s.faces) for s in scr.strokes)
                print(f"{p}: scribbles on {scr.mesh!r}: {len(scr.strokes)} strokes, {n} faces, "
                      f"labels {', '.join(scr.label_names)}")
            else:
                mesh = load_mesh(p)
                print(f"{p}: {mesh.report.summary()}")
        except ScribblesegError as e:
            print(f"error: {e}", file=sys.stderr)
            status = 2
    return status


def _output_folder(path: str) -> Path:
    """`path` as an output folder, created if needed; checked before any work is done."""
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise ScribblesegError("exists and is not a folder; choose another --out", out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ScribblesegError(f"cannot create the output folder ({e.strerror})", out) from None
    return out


def _bar(total, desc: str, items=None):
    from tqdm import tqdm

    return tqdm(items, total=total, desc=desc, unit="shape", file=sys.stderr, leave=False)


def _write_file_labels(out: Path, mesh, file_labels, label_names, confidence=None) -> None:
    """``out/<mesh>.seg`` and ``.ply`` for labels per file face (the PLY with the confidence
    per file face, when given)."""
    from scribbleseg_core.formats.export import export_labeled_mesh
    from scribbleseg_core.formats.labels import LabelSet

    export_labeled_mesh(out, mesh.name, mesh.V_file, mesh.F_file, file_labels,
                        LabelSet.from_names(label_names), formats=["seg", "ply"], confidence=confidence)


def _signature_pass(paths, args, meshes=None) -> None:
    """Signatures of the meshes not yet cached, in parallel on Dask (the path of ``predict``)."""
    from scribbleseg_core.scale.run import signatures_many

    if len(paths) < 2 and not args.scheduler:
        return  # one mesh: no cluster to start
    bar = None if args.quiet else _bar(len(paths), "signatures")
    summary = signatures_many(paths, meshes=meshes, workers=args.workers, scheduler=args.scheduler,
                              progress=None if bar is None else (lambda done, total: bar.update(done - bar.n)))
    if bar is not None:
        bar.close()
    if not args.quiet and summary.done:
        print(f"signatures of {summary.done} shapes in {summary.seconds:.1f} s", file=sys.stderr)


def _read_full_labels(folder: Path, paths, meshes, scribbles: list, names: list) -> None:
    """Replace the scribbles of every mesh with a ``folder/<stem>.seg`` by its full labels (in
    place), the ids naming ``folder/label_names.txt`` when present (new names appended to
    `names`), else `names` itself."""
    import numpy as np

    from scribbleseg_core.evaluation.psb import read_label_names
    from scribbleseg_core.formats.seg import read_seg

    if not folder.is_dir():
        raise ScribblesegError("not a folder (--labels expects a folder of <mesh name>.seg files)", folder)
    listed = folder / "label_names.txt"
    if listed.is_file():
        try:
            seg_names = read_label_names(listed)
        except ValueError:
            raise ScribblesegError("expected '<id> <name>' on every line", listed) from None
        names += [n for n in seg_names if n not in names]
        remap = np.array([names.index(n) for n in seg_names], dtype=np.int64)
    elif names:
        remap = np.arange(len(names))
    else:
        raise ScribblesegError("no label_names.txt here and no scribble files to name the labels", folder)
    found = 0
    for i, path in enumerate(paths):
        f = folder / f"{path.stem}.seg"
        if not f.is_file():
            continue
        labels = read_seg(f, meshes[i].num_file_faces)
        if labels.size and (labels.min() < -1 or labels.max() >= len(remap)):
            raise ScribblesegError(f"label ids span [{labels.min()}, {labels.max()}]; only 0 to {len(remap) - 1} "
                                   "have names (-1: unlabeled)", f)
        scribbles[i] = np.where(labels >= 0, remap[np.maximum(labels, 0)], -1)
        found += 1
    if not found:
        raise ScribblesegError(f"no <mesh name>.seg for any mesh of the collection ({len(paths)} meshes)", folder)


def _cmd_segment(args) -> int:
    import time

    from scribbleseg_core.engine.optimize import SegmentParams
    from scribbleseg_core.engine.pipeline import (
        FeaturesDone,
        Predicted,
        Scored,
        StepDone,
        Suggested,
        collection_run,
    )
    from scribbleseg_core.formats.collection import find_collection
    from scribbleseg_core.formats.mesh import load_mesh
    from scribbleseg_core.store.model_file import save_model

    t0 = time.perf_counter()
    out = _output_folder(args.out)
    coll = find_collection(args.folder)
    if not coll.scribbles and not args.labels:
        raise ScribblesegError(f"no scribble files in {args.folder} or its scribbles/ folder")
    meshes = []
    for path in coll.meshes:
        mesh = load_mesh(path)
        scr = coll.scribbles.get(path)
        if scr is not None and scr.num_faces != mesh.num_file_faces:
            raise ScribblesegError(f"scribbles for {path.name} have num_faces {scr.num_faces}, "
                                   f"the mesh has {mesh.num_file_faces}")
        meshes.append(mesh)
    scribbles = [coll.face_labels(path) for path in coll.meshes]
    label_names = list(coll.label_names)
    if args.labels:
        _read_full_labels(Path(args.labels), coll.meshes, meshes, scribbles, label_names)
    _signature_pass(coll.meshes, args, meshes)
    params = SegmentParams(method=args.method)
    bar = None if args.quiet else _bar(len(meshes), "features")
    last, predicted, confidence, hint = None, {}, {}, None
    for msg in collection_run(meshes, scribbles, label_names, params, num_patches=args.patches):
        if isinstance(msg, FeaturesDone):
            if bar is not None:
                bar.update(1)
                if msg.done == msg.total:
                    bar.close()
        elif isinstance(msg, StepDone):
            last = msg
            if not args.quiet:
                snap, e = msg.snapshot, msg.snapshot.energy
                print(f"  round {snap.iteration} {snap.phase:<8} E = {e.total:.1f} "
                      f"(scribbles {e.scribble:.1f}, network {e.network:.1f}, smoothness {e.smoothness:.1f}) "
                      f"{snap.seconds:.1f} s", file=sys.stderr)
        elif isinstance(msg, Predicted):
            predicted[msg.index] = msg.file_labels
        elif isinstance(msg, Scored):
            confidence[msg.index] = msg.file_confidence
        elif isinstance(msg, Suggested):
            hint = msg
    for i, labels in [*zip(last.indices, last.file_labels), *predicted.items()]:
        _write_file_labels(out, meshes[i], labels, label_names, confidence.get(i))
    save_model(out / "model", last.snapshot.model)
    if not args.quiet:
        painted = sum(s is not None for s in scribbles)
        print(f"segmented {len(last.indices) + len(predicted)} shapes ({painted} with scribbles) "
              f"in {time.perf_counter() - t0:.1f} s; wrote {out}", file=sys.stderr)
        if hint is not None:
            print(f"the unsure region that weighs most is on {meshes[hint.index].path.name}, around face {hint.file_face} "
                  f"({len(hint.file_faces)} unconfident faces)", file=sys.stderr)
    return 0


def _cmd_predict(args) -> int:
    from scribbleseg_core.scale.inputs import gather_sources
    from scribbleseg_core.scale.run import ERRORS_NAME, predict_many

    out = _output_folder(args.out)
    sources = gather_sources(args.inputs, exclude=out)
    if not sources:
        raise ScribblesegError(f"no mesh files ({', '.join(MESH_EXTENSIONS)}) in {' '.join(args.inputs)}")
    bar = None if args.quiet else _bar(len(sources), "predict")

    def progress(done: int, total: int) -> None:
        if bar is not None:
            bar.update(done - bar.n)

    summary = predict_many(args.model, sources, out, workers=args.workers, scheduler=args.scheduler,
                           force=args.force, num_patches=args.patches, confidence=args.confidence, progress=progress)
    if bar is not None:
        bar.close()
    if not args.quiet:
        print(summary.table(), file=sys.stderr)
    for e in summary.errors[:5]:
        print(f"error: {e['message']}", file=sys.stderr)
    if summary.failed:
        more = f" ({summary.failed - 5} more)" if summary.failed > 5 else ""
        print(f"{summary.failed} of {len(sources)} shapes failed{more}: see {out / ERRORS_NAME}", file=sys.stderr)
    return 0 if summary.ok else 1


def _cmd_bench(args) -> int:
    from scribbleseg_core.evaluation.benchmark import bench
    from scribbleseg_core.evaluation.psb import categories
    from scribbleseg_core.formats.mesh import find_meshes

    root = Path(args.data)
    if not (root.is_dir() and any(p.is_dir() and (p / "labels").is_dir() for p in root.iterdir())):
        raise ScribblesegError(f"{root}: not a benchmark folder (expected <Category>/labels, scribbles/ and meshes)")
    modes = {"both": ["train", "test"], "all": ["train", "test", "collection"]}.get(args.mode, [args.mode])
    progress = None if args.quiet else (lambda msg: print(f"  {msg}", file=sys.stderr, flush=True))
    params = _bench_params(args)
    out = _output_folder(args.out)
    cats = args.categories or categories(root)
    _signature_pass([m for c in cats if (root / c).is_dir() for m in find_meshes(root / c)], args)
    report = bench(root, out, modes=modes, cats=args.categories, folds=args.folds,
                   scribbled=args.scribbled, coverage=args.coverage, strokes=args.strokes, seed=args.seed,
                   labels=args.labels,
                   params=params, progress=progress)
    print((out / "report.md").read_text())
    return 0 if report["verified"] else 1


def _bench_params(args):
    """The engine's parameters for `bench`: the defaults, with the options given."""
    from dataclasses import replace

    from scribbleseg_core.engine.optimize import SegmentParams

    base = SegmentParams(method=args.method)
    given = lambda **kw: {k: v for k, v in kw.items() if v is not None}  # noqa: E731
    return replace(base, network=replace(base.network, threads=args.threads, **given(seed=args.network_seed)),
                   propagation=replace(base.propagation, **given(contrast=args.contrast, walk=args.walk,
                                                                 walk_reach=args.walk_reach,
                                                                 convex=args.convex, boundary=args.boundary)),
                   **given(local_shape=args.local_shape, label_context=args.label_context, rounds=args.rounds,
                           decided=args.decided))


def _cmd_bench_merge(args) -> int:
    from scribbleseg_core.evaluation.benchmark import merge_reports

    out = _output_folder(args.out)
    report = merge_reports(Path(args.data), [Path(p) for p in args.parts], out)
    print((out / "report.md").read_text())
    return 0 if report["verified"] else 1


def _int_at_least(low: int):
    """argparse type: an int no smaller than `low` (else argparse's one-line usage error)."""
    def parse(text: str) -> int:
        value = int(text)
        if value < low:
            raise argparse.ArgumentTypeError(f"must be at least {low}; got {value}")
        return value
    return parse


def _fraction(text: str) -> float:
    """argparse type: a float in [0, 1]."""
    value = float(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must lie in [0, 1]; got {value}")
    return value


def _non_negative(text: str) -> float:
    """argparse type: a float ≥ 0."""
    value = float(text)
    if not value >= 0.0:  # nan too
        raise argparse.ArgumentTypeError(f"must not be negative; got {value}")
    return value


def _cluster_options(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--workers", type=_int_at_least(1), default=None,
                   help=f"compute {what} on a Dask LocalCluster of this many processes (default: one per core)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="use an existing Dask cluster instead (e.g. tcp://host:8786); the files and the "
                        "signature cache must be on a file system its workers share")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="scribbleseg", description="Scribble-based segmentation of 3D shape collections."
    )
    parser.add_argument("--version", action="version", version=f"scribbleseg {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("info", help="report what a mesh or scribble file holds and what was repaired")
    p.add_argument("files", nargs="+", help="mesh (.off .obj .ply .stl .glb .gltf) or scribble (.json) files")
    p.set_defaults(func=_cmd_info)

    p = sub.add_parser("segment", help="segment a folder of meshes from its scribble files; predict its unscribbled meshes")
    p.add_argument("folder", help="meshes plus scribble files <name>.json (beside them or in scribbles/)")
    p.add_argument("--out", required=True, help="output folder: <mesh>.seg, <mesh>.ply, model/")
    p.add_argument("--patches", type=int, default=50, help="primitive patches per shape (default 50)")
    p.add_argument("--method", choices=METHODS, default="face",
                   help="face: the alternation on faces (default); paper: the paper's patch-level alternation")
    p.add_argument("--labels", metavar="FOLDER",
                   help="fully labeled shapes: FOLDER/<mesh name>.seg (a label id per face, -1 unlabeled), ids "
                        "naming FOLDER/label_names.txt ('<id> <name>' lines) or else the scribbles' labels; such "
                        "a shape trains on every face's label, in place of its scribbles")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    _cluster_options(p, "the signatures")
    p.set_defaults(func=_cmd_segment)

    p = sub.add_parser("predict", help="segment meshes with a trained model, in parallel on Dask",
                       description="Segment meshes with a trained model. Shapes run in parallel on a Dask "
                                   "LocalCluster (one process per core) or on an existing cluster (--scheduler). "
                                   "A rerun skips shapes already done with this model (OUT/manifest.jsonl); "
                                   "shapes that fail are listed in OUT/errors.json and the exit status is 1.")
    p.add_argument("model", help="a model folder written by 'segment' (OUT/model)")
    p.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="mesh files, folders (searched recursively) or .txt files listing paths")
    p.add_argument("--out", required=True, help="output folder: <name>.seg and <name>.ply per mesh, "
                                                "keeping the folders' layout")
    p.add_argument("--force", action="store_true", help="redo shapes already done")
    _cluster_options(p, "the shapes")
    p.add_argument("--patches", type=int, default=50, help="primitive patches per shape (paper-faithful models)")
    p.add_argument("--confidence", action="store_true",
                   help="also write each face's confidence in [0, 1]: PLY face property 'confidence', "
                        "<name>.labels.json with a summary per label, <name>.vtp with cell data Label and Confidence")
    p.add_argument("--quiet", action="store_true", help="no progress bar or summary")
    p.set_defaults(func=_cmd_predict)

    p = sub.add_parser("bench", help="evaluate on PSB-style data (../shared/psb) and write a report")
    p.add_argument("data", help="folder of <Category>/ folders with meshes, labels/, scribbles/")
    p.add_argument("--mode", choices=["train", "test", "both", "collection", "given", "all"], default="both",
                   help="train: all shapes painted, scored; test: k folds, held-out shapes predicted; both; "
                        "collection: N painted, one run on all, the others (predicted) scored; "
                        "given: the shapes with scribble files painted, the others predicted")
    p.add_argument("--folds", type=_int_at_least(2), default=5, help="test mode: folds by sorted id (20 = leave-one-out)")
    p.add_argument("--scribbled", type=_int_at_least(1), nargs="+", default=[1, 3, 5, 10],
                   help="collection mode: shapes per category that keep their scribbles")
    p.add_argument("--coverage", type=_fraction, default=1.0, help="keep this central fraction of every stroke")
    p.add_argument("--strokes", choices=["all", "one"], default="all",
                   help="'one': keep only the longest stroke of every label on a shape (one leg of four painted)")
    p.add_argument("--categories", nargs="+")
    p.add_argument("--method", choices=METHODS, default="face",
                   help="face: the alternation on faces (default); paper: the paper's patch-level alternation")
    p.add_argument("--labels", choices=["scribbles", "truth"], default="scribbles",
                   help="what the painted shapes are given: their scribbles (default), or their full ground-truth "
                        "labels (the learner's ceiling, comparable with fully supervised methods)")
    p.add_argument("--seed", type=int, default=0, help="scribbled and collection modes: which shapes keep scribbles")
    p.add_argument("--network-seed", type=int, default=None,
                   help="seed of the networks' initialization and face sampling, and of the patch codebook "
                        "(default NetworkParams.seed); rerun with others to see how much a figure owes to it")
    p.add_argument("--threads", type=_int_at_least(1), default=None,
                   help="torch threads for training (default: the cores this process may use; 1 when running two "
                        "benchmarks at once)")
    p.add_argument("--rounds", type=_int_at_least(1), default=None, help="network/graph-cut rounds at most")
    p.add_argument("--contrast", type=_non_negative, default=None,
                   help="SDF contrast of the face energy's smoothness (default PropagateParams.contrast; 0 = off)")
    p.add_argument("--walk", type=_non_negative, default=None,
                   help="random-walk term of the face energy (default PropagateParams.walk; 0 = off)")
    p.add_argument("--walk-reach", type=_non_negative, default=None,
                   help="how far the walk goes before it stops at the network's label (PropagateParams.walk_reach)")
    p.add_argument("--decided", type=_fraction, default=None,
                   help="the first round's networks learn the faces the walk from the strokes reaches with at "
                        "least this chance, and a tenth of the others (default SegmentParams.decided; 0 = every face)")
    p.add_argument("--convex", type=_fraction, default=None,
                   help="weight of convex creases against concave ones in the face energy's smoothness and walk "
                        "(default PropagateParams.convex; 0.1 = the dual graph's crease metric)")
    p.add_argument("--boundary", type=_non_negative, default=None,
                   help="weight of the learned boundary term on shapes without scribbles (default "
                        "PropagateParams.boundary; 0 = off: the crease rule there, no boundary classifier)")
    p.add_argument("--local-shape", action=argparse.BooleanOptionalAction, default=None,
                   help="the local extrinsic shape around each face among the network's inputs "
                        "(default SegmentParams.local_shape; --no-local-shape: the signatures and their context only)")
    p.add_argument("--label-context", action=argparse.BooleanOptionalAction, default=None,
                   help="the learner's second stage, which reads where the first stage puts each label around "
                        "the face (default SegmentParams.label_context)")
    p.add_argument("--out", required=True)
    p.add_argument("--quiet", action="store_true")
    _cluster_options(p, "the signatures")
    p.set_defaults(func=_cmd_bench)

    p = sub.add_parser("bench-merge", help="merge benchmark reports run apart (e.g. one per core, by categories or by modes)")
    p.add_argument("data", help="the benchmark data the parts were run on")
    p.add_argument("parts", nargs="+", help="output folders of 'scribbleseg bench'")
    p.add_argument("--out", required=True)
    p.set_defaults(func=_cmd_bench_merge)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except ScribblesegError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
