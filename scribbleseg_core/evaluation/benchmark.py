"""``scribbleseg bench``: the PSB evaluation, reproducing the paper's tables.

Modes (per category, shapes in natural id order):

train
    All shapes scribbled; score the labels the optimization gives them (Table 1).
test
    K folds by sorted id: train on the other folds' scribbled shapes, predict the held-out
    fold without its scribbles; every shape predicted once (Table 2 used leave-one-out:
    ``--folds 20``).
collection
    Only N shapes keep their scribbles (drawn with a fixed, reported seed); one run on the
    whole category, as the app's *Segment collection*: the painted shapes are optimized and
    the others, predicted at every round's cut, are scored.
given
    Train on the shapes that have a scribble file and score them (``given_scribbled``);
    predict and score the others (``given_unscribbled``). For collections like the demo
    assets, scribbled on a few shapes only.

Scores: against the label maps (label ids are the segments) and against the PSB human
segmentations (predicted labels split into connected components, scored against each human
segmentation, averaged). Predicted ``.seg`` files are written per shape, and every reported
Rand Index error is recomputed from those files before the report is written.
"""

from __future__ import annotations

import json
import resource
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from scribbleseg_core.engine.optimize import SegmentParams, segment_collection
from scribbleseg_core.engine.predict import predict_shape
from scribbleseg_core.engine.shape import prepare_shape
from scribbleseg_core.evaluation.metrics import (
    consistency_errors,
    cut_discrepancy,
    hamming_distance,
    labeling_accuracy,
    rand_index_error,
    rand_index_error_area,
    split_components,
)
from scribbleseg_core.evaluation.psb import categories as list_categories
from scribbleseg_core.formats.mesh import Mesh, find_meshes, load_mesh
from scribbleseg_core.formats.scribbles import Scribbles, Stroke, read_scribbles
from scribbleseg_core.formats.seg import read_seg, write_seg
from scribbleseg_core.geometry.measures import face_areas
from scribbleseg_core.signatures.features import cached_face_features

#: The benchmark's modes (see the module docstring).
MODES: tuple[str, ...] = ("train", "test", "collection", "given")
#: What the painted shapes are given: their scribbles, or their full ground truth (the
#: learner's ceiling, comparable with fully supervised methods).
LABEL_SOURCES: tuple[str, ...] = ("scribbles", "truth")


@dataclass
class Item:
    mesh: Mesh
    scribbles: Scribbles | None
    truth: np.ndarray
    human: list[np.ndarray] = field(default_factory=list)


def load_category(root: Path, cat: str) -> tuple[list[Item], tuple[str, ...], float]:
    """Meshes, scribbles, label maps and human segmentations; seconds of feature extraction."""
    folder = root / cat
    human = {}
    if (folder / "benchmark_seg.npz").is_file():
        with np.load(folder / "benchmark_seg.npz", allow_pickle=False) as z:
            for key in z.files:
                human.setdefault(key.rsplit("_", 1)[0], []).append(z[key].astype(np.int64))
    items, t_feat = [], 0.0
    for path in find_meshes(folder):
        mesh = load_mesh(path)
        scr_path = folder / "scribbles" / f"{path.stem}.json"
        scr = read_scribbles(scr_path, num_faces=mesh.num_file_faces) if scr_path.is_file() else None
        t = time.perf_counter()
        cached_face_features(mesh.V, mesh.F)
        t_feat += time.perf_counter() - t
        truth = read_seg(folder / "labels" / f"{path.stem}.seg", mesh.num_file_faces)
        items.append(Item(mesh, scr, truth, human.get(path.stem, [])))
    names = next((it.scribbles.label_names for it in items if it.scribbles is not None), None)
    if names is None:
        raise ValueError(f"{folder}: no scribble files in scribbles/")
    return items, names, t_feat


def keep_coverage(scr: Scribbles | None, coverage: float) -> Scribbles | None:
    """Keep the central `coverage` fraction (by count, at least one face) of every stroke."""
    if scr is None or coverage >= 1:
        return scr
    strokes = []
    for s in scr.strokes:
        n = len(s.faces)
        keep = max(1, int(round(n * coverage))) if n else 0
        start = (n - keep) // 2
        strokes.append(Stroke(s.label, s.faces[start : start + keep]))
    return replace(scr, strokes=tuple(strokes))


#: How many of a shape's strokes a benchmark keeps: ``"all"``, or ``"one"`` per label (its longest).
STROKE_SETS = ("all", "one")


def keep_strokes(scr: Scribbles | None, strokes: str) -> Scribbles | None:
    """The strokes of `scr` a benchmark keeps (:data:`STROKE_SETS`): with ``"one"``, of every
    label only its longest stroke (the first of equals), as a user paints one leg of four."""
    if strokes not in STROKE_SETS:
        raise ValueError(f"strokes must be one of {', '.join(STROKE_SETS)}; got {strokes!r}")
    if scr is None or strokes == "all":
        return scr
    longest: dict[int, Stroke] = {}
    for s in scr.strokes:
        if s.label not in longest or len(s.faces) > len(longest[s.label].faces):
            longest[s.label] = s
    return replace(scr, strokes=tuple(s for s in scr.strokes if longest[s.label] is s))


def shape_scores(item: Item, labels_file: np.ndarray) -> dict:
    """Every metric of one shape's predicted file-face labels."""
    V, F, gt = item.mesh.V_file, item.mesh.F_file, item.truth
    area = face_areas(V, F)
    gce, lce = consistency_errors(labels_file, gt, area)
    miss, fa, hd = hamming_distance(labels_file, gt, area)
    out = {
        "ri_error": rand_index_error(labels_file, gt),
        "ri_error_area": rand_index_error_area(labels_file, gt, area),
        "gce": gce, "lce": lce, "hamming_missing": miss, "hamming_false_alarm": fa, "hamming": hd,
        "cut_discrepancy": cut_discrepancy(V, F, labels_file, gt),
        "accuracy_area": labeling_accuracy(labels_file, gt, area),
    }
    if item.human:
        comps = split_components(F, labels_file)
        out["ri_error_human"] = float(np.mean([rand_index_error(comps, h) for h in item.human]))
    return out


#: Where a mode's time goes: the snapshot phases, and the steps around the optimization.
_PHASES = {"init": "propagation", "train": "training", "graphcut": "cuts"}
TIME_PARTS: tuple[str, ...] = ("shapes", "propagation", "training", "cuts", "prediction")


def _run(shapes, names, params, clock: dict):
    """The last snapshot of the optimization; its steps' seconds added to `clock` (what the
    run spent after its last cut, the model's last training, counted as training)."""
    snap, steps = None, 0.0
    for snap in segment_collection(shapes, names, params):
        if snap.phase in _PHASES:
            clock[_PHASES[snap.phase]] += snap.seconds
            steps += snap.seconds
    clock["training"] += max(0.0, snap.seconds - steps)  # the "done" snapshot's seconds are the whole run's
    return snap


class _Clock(dict):
    """Seconds per part of a mode (:data:`TIME_PARTS`)."""

    def __init__(self):
        super().__init__({part: 0.0 for part in TIME_PARTS})

    def timed(self, part: str, f, *args):
        t = time.perf_counter()
        try:
            return f(*args)
        finally:
            self[part] += time.perf_counter() - t


def run_mode(items, names, mode: str, params: SegmentParams, *, folds=5, scribbled=None, coverage=1.0, seed=0,
             labels: str = "scribbles", strokes: str = "all"):
    """Predicted file-face labels per scored shape, ``{index: labels}`` (``{(group, index):
    labels}`` in mode ``given``), and the seconds the mode took per part (:data:`TIME_PARTS`). With ``labels="truth"`` the
    painted shapes are given their full ground-truth labels instead of their scribbles (a
    fully labeled shape, as a ``.seg`` file beside a mesh). `strokes` and `coverage` thin the
    scribbles first (:func:`keep_strokes`, :func:`keep_coverage`)."""
    if labels not in LABEL_SOURCES:
        raise ValueError(f"labels must be one of {', '.join(LABEL_SOURCES)}; got {labels!r}")
    scr = [keep_coverage(keep_strokes(it.scribbles, strokes), coverage) for it in items]
    n = len(items)
    if labels == "truth":
        scr = [it.truth if s is not None else None for it, s in zip(items, scr)]
    else:
        scr = [None if s is None else s.face_labels() for s in scr]
    clock = _Clock()
    with_scribbles = lambda i: clock.timed("shapes", prepare_shape, items[i].mesh, scr[i])  # noqa: E731
    without = lambda i: clock.timed("shapes", prepare_shape, items[i].mesh)  # noqa: E731
    predict = lambda model, s: clock.timed("prediction", predict_shape, model, s)  # noqa: E731
    out = {}
    if mode == "train":
        shapes = [with_scribbles(i) for i in range(n)]
        snap = _run(shapes, names, params, clock)
        for i, (s, lab) in enumerate(zip(shapes, snap.labels)):
            out[i] = s.mesh.labels_to_file(lab)
    elif mode == "test":
        fold_of = np.arange(n) * folds // n
        for f in range(folds):
            snap = _run([with_scribbles(i) for i in np.flatnonzero(fold_of != f)], names, params, clock)
            for i in np.flatnonzero(fold_of == f):
                s = without(i)
                out[int(i)] = s.mesh.labels_to_file(predict(snap.model, s))
    elif mode == "collection":  # one run on every shape; the unpainted ones without their scribbles
        chosen = np.sort(np.random.default_rng(seed).choice(n, size=scribbled, replace=False))
        shapes = [with_scribbles(i) if i in chosen else without(i) for i in range(n)]
        snap = _run(shapes, names, params, clock)
        for i in sorted(set(range(n)) - set(chosen.tolist())):  # method "paper" leaves them to predict
            labels = snap.labels[i] if (snap.labels[i] >= 0).any() else predict(snap.model, shapes[i])
            out[i] = shapes[i].mesh.labels_to_file(labels)
    elif mode == "given":
        chosen = [i for i in range(n) if scr[i] is not None]
        shapes = [with_scribbles(i) for i in chosen]
        snap = _run(shapes, names, params, clock)
        for i, s, lab in zip(chosen, shapes, snap.labels):
            out[("given_scribbled", int(i))] = s.mesh.labels_to_file(lab)
        for i in sorted(set(range(n)) - set(chosen)):
            s = without(i)
            out[("given_unscribbled", i)] = s.mesh.labels_to_file(predict(snap.model, s))
    else:
        raise ValueError(f"mode must be one of {', '.join(MODES)}; got {mode!r}")
    return out, clock


def _mean(rows, key):
    vals = [r[key] for r in rows if key in r and np.isfinite(r[key])]
    return float(np.mean(vals)) if vals else float("nan")


def bench(root: Path, out: Path, *, modes=("train", "test"), cats=None, folds=5, scribbled=(1, 3, 5, 10),
          coverage=1.0, seed=0, labels="scribbles", strokes="all", params: SegmentParams | None = None,
          progress=None) -> dict:
    """Run the benchmark and write the report into `out`; returns the report."""
    params = params or SegmentParams()
    cats = cats or list_categories(root)
    report = {"settings": {"modes": list(modes), "folds": folds, "scribbled": list(scribbled), "coverage": coverage,
                           "strokes": strokes, "seed": seed, "labels": labels, "method": params.method, "rounds": params.rounds,
                           "context_scales": list(params.context_scales),
                           "local_shape": params.local_shape,
                           "label_context": params.label_context,
                           "propagation": asdict(params.propagation),
                           "network": {k: v for k, v in asdict(params.network).items() if k != "threads"}},
              "categories": {}}
    runs = [(m, None) for m in modes if m != "collection"]
    runs += [("collection", k) for k in scribbled if "collection" in modes]
    for cat in cats:
        items, names, t_feat = load_category(root, cat)
        entry = {"shapes": len(items), "feature_seconds_per_shape": t_feat / len(items)}
        for mode, k in runs:
            key = mode if k is None else f"{mode}_{k}"
            if progress:
                progress(f"{cat} {key}")
            preds, sec = run_mode(items, names, mode, params, folds=folds, scribbled=k, coverage=coverage, seed=seed,
                                  labels=labels, strokes=strokes)
            groups: dict[str, dict] = {}
            for idx, pair in preds.items():
                group, i = idx if isinstance(idx, tuple) else (key, idx)
                groups.setdefault(group, {})[i] = pair
            for group, gpreds in groups.items():
                rows = {}
                for i, lab in gpreds.items():
                    stem = items[i].mesh.name
                    write_seg(out / cat / group / f"{stem}.seg", lab)
                    rows[stem] = shape_scores(items[i], lab)
                summary = {m: _mean(rows.values(), m) for m in next(iter(rows.values()))}
                summary["seconds_per_shape"] = sum(sec.values()) / len(items)
                summary["seconds"] = dict(sec)
                summary["scored_shapes"] = len(rows)
                entry[group] = {"summary": summary, "shapes": rows}
        entry["peak_memory_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        report["categories"][cat] = entry
    return finish_report(root, out, report)


def finish_report(root: Path, out: Path, report: dict) -> dict:
    """Verify `report` against the .seg files in `out`, average it over categories, and write
    ``report.json``, ``report.md`` and ``chart.png`` into `out`; returns the report."""
    report["verified"] = verify(root, out, report)
    report["average"] = {key: {m: _mean([c[key]["summary"] for c in report["categories"].values() if key in c], m)
                               for m in ("ri_error", "ri_error_human", "seconds_per_shape")}
                         for key in {k for c in report["categories"].values() for k in c if isinstance(c[k], dict)}}
    out.mkdir(parents=True, exist_ok=True)
    (out / "report.json").write_text(json.dumps(report, indent=1))
    (out / "report.md").write_text(markdown(report, root))
    chart(report, root, out / "chart.png")
    return report


def merge_reports(root: Path, parts: list[Path], out: Path) -> dict:
    """One report from benchmarks run apart (say one per core, over different categories,
    or one mode here and another there).

    Every part must have been run with the same settings but for the modes and the
    collection sizes (``scribbled``); a category's mode in several parts is refused. The
    parts' ``.seg`` files are copied into `out` and every error is verified again from them.

    Parameters
    ----------
    root : Path
        The benchmark data the parts were run on.
    parts : list of Path
        Output folders of ``scribbleseg bench``.
    out : Path
        Where the merged report goes (may not be one of `parts`).
    """
    import shutil

    from scribbleseg_core.errors import ScribblesegError

    out = Path(out)
    if any(out.resolve() == Path(p).resolve() for p in parts):
        raise ScribblesegError(f"{out}: the merged report cannot go into one of its parts")
    merged, all_modes, sizes = None, [], set()
    for part in map(Path, parts):
        path = part / "report.json"
        try:
            rep = json.loads(path.read_text())
            settings, categories = dict(rep["settings"]), rep["categories"]
            modes = settings.pop("modes")
            scribbled = settings.pop("scribbled")
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as e:
            raise ScribblesegError(f"{path}: not a benchmark report ({e})") from None
        if merged is None:
            merged = {"settings": settings, "categories": {}}
        elif settings != merged["settings"]:
            raise ScribblesegError(f"{path}: run with other settings than {parts[0]}: {settings} vs {merged['settings']}")
        all_modes += [m for m in modes if m not in all_modes]
        if "collection" in modes:
            sizes.update(scribbled)
        for cat, entry in categories.items():
            have = merged["categories"].setdefault(cat, {})
            twice = [key for key, val in entry.items() if isinstance(val, dict) and key in have]
            if twice:
                raise ScribblesegError(f"{path}: category {cat} ({', '.join(twice)}) is in more than one part")
            have.update({key: val for key, val in entry.items() if isinstance(val, dict) or key not in have})
            if (part / cat).is_dir():
                shutil.copytree(part / cat, out / cat, dirs_exist_ok=True)
    if merged is None:
        raise ScribblesegError("no reports to merge")
    merged["settings"] = {"modes": all_modes, "scribbled": sorted(sizes), **merged["settings"]}
    merged["categories"] = dict(sorted(merged["categories"].items()))
    return finish_report(root, out, merged)


def verify(root: Path, out: Path, report: dict) -> bool:
    """Recompute every shape's Rand Index error from the written .seg files; raise on mismatch."""
    for cat, entry in report["categories"].items():
        for key, val in entry.items():
            if not isinstance(val, dict):
                continue
            for stem, row in val["shapes"].items():
                truth = read_seg(root / cat / "labels" / f"{stem}.seg")
                pred = read_seg(out / cat / key / f"{stem}.seg", len(truth))
                again = rand_index_error(pred, truth)
                if not np.isclose(again, row["ri_error"], atol=1e-12):
                    raise AssertionError(f"{cat}/{key}/{stem}: report says {row['ri_error']}, .seg gives {again}")
    return True


def _paper(root: Path) -> dict:
    path = root / "paper_results.json"
    return json.loads(path.read_text()) if path.is_file() else {}


def markdown(report: dict, root: Path) -> str:
    paper = _paper(root)
    t1 = paper.get("table1_training_shapes", {})
    t2 = paper.get("table2_leave_one_out", {})
    lines = ["# scribbleseg on PSB", "", f"Settings: `{json.dumps(report['settings'])}`", ""]
    keys = {k for c in report["categories"].values() for k in c if isinstance(c[k], dict)}
    # the modes by name, collection_N by N (not collection_10 before collection_3)
    keys = sorted(keys, key=lambda k: (k.rstrip("0123456789"), int(k[len(k.rstrip("0123456789")):] or 0)))
    for key in keys:
        ref = t1 if key == "train" else t2 if key == "test" else {}
        methods = list(ref)
        extra = "".join(f" {mth} |" for mth in methods)
        lines += [f"## {key}", "", "| category | ours RI err | vs human | GCE | LCE | Hamming | CD | s/shape |" + extra,
                  "|---" * (8 + len(methods)) + "|"]
        for cat, c in report["categories"].items():
            if key not in c:
                continue
            s = c[key]["summary"]
            lines.append(f"| {cat} | {s['ri_error']:.3f} | {s.get('ri_error_human', float('nan')):.3f} | "
                         f"{s['gce']:.3f} | {s['lce']:.3f} | {s['hamming']:.3f} | {s['cut_discrepancy']:.3f} | "
                         f"{s['seconds_per_shape']:.1f} |" + "".join(f" {ref[mth].get(cat, float('nan')):.3f} |" for mth in methods))
        avg = report["average"][key]
        cats = [c for c in report["categories"] if key in report["categories"][c]]
        lines.append(f"| **average** | **{avg['ri_error']:.3f}** | {avg['ri_error_human']:.3f} | | | | | "
                     f"{avg['seconds_per_shape']:.1f} |" + "".join(f" {np.nanmean([ref[mth].get(c, np.nan) for c in cats]):.3f} |" for mth in methods))
        lines.append("")
    lines += ["## cost", "", "| category | features s/shape (this run: near 0 when cached; `make bench` times them cold) | peak memory MB |", "|---|---|---|"]
    for cat, c in report["categories"].items():
        lines.append(f"| {cat} | {c['feature_seconds_per_shape']:.2f} | {c['peak_memory_mb']:.0f} |")
    lines += ["", "## time", "", "Seconds per category and mode (this run's machine and load), by part: "
              "shapes (dual graph, patches, cached signatures), propagation (the initial labels), training, "
              "cuts, prediction.", "", "| category | mode | " + " | ".join(TIME_PARTS) + " | total |",
              "|---" * (len(TIME_PARTS) + 3) + "|"]
    for cat, c in report["categories"].items():
        for key in keys:
            sec = c.get(key, {}).get("summary", {}).get("seconds")
            if sec:
                lines.append(f"| {cat} | {key} | " + " | ".join(f"{sec.get(p, 0.0):.1f}" for p in TIME_PARTS)
                             + f" | {sum(sec.values()):.1f} |")
    lines += ["", f"Every Rand Index error above was recomputed from the written .seg files: {report['verified']}.", ""]
    return "\n".join(lines)


def chart(report: dict, root: Path, path: Path) -> None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    paper = _paper(root)
    ref = {"train": paper.get("table1_training_shapes", {}).get("paper_train", {}),
           "test": paper.get("table2_leave_one_out", {}).get("paper_test", {})}
    keys = [k for k in ("train", "test") if any(k in c for c in report["categories"].values())]
    if not keys:
        return
    fig, axes = plt.subplots(len(keys), 1, figsize=(11, 3.2 * len(keys)), squeeze=False)
    for ax, key in zip(axes[:, 0], keys):
        cats = [c for c in report["categories"] if key in report["categories"][c]]
        x = np.arange(len(cats))
        ours = [report["categories"][c][key]["summary"]["ri_error"] for c in cats]
        theirs = [ref[key].get(c, np.nan) for c in cats]
        ax.bar(x - 0.2, ours, 0.4, label="scribbleseg")
        ax.bar(x + 0.2, theirs, 0.4, label="Shu et al.")
        ax.set_xticks(x, cats, rotation=0, fontsize=8)
        ax.set_ylabel("Rand Index error")
        ax.set_title(f"{key} shapes")
        ax.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
