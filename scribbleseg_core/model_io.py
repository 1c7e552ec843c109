"""Save and load trained models as plain files that cannot execute code on load.

A model folder holds ``model.json`` (format, versions, label names, parameters),
``weights.pt`` (a torch state dict, read with ``weights_only=True``) and ``arrays.npz``
(normalization and codebook, read with ``allow_pickle=False``).
"""

from __future__ import annotations

import dataclasses
import io
import json
import os
from pathlib import Path

import numpy as np

from scribbleseg_core import __version__
from scribbleseg_core.atomic import atomic_write_bytes, atomic_write_text
from scribbleseg_core.context import LOCAL_SHAPE_PER_SCALE
from scribbleseg_core.cores import CoreParams
from scribbleseg_core.dual_graph import CONVEX_FACTOR
from scribbleseg_core.errors import ModelFileError
from scribbleseg_core.features import FEATURE_VERSION, NUM_FEATURES
from scribbleseg_core.network import FaceClassifier, NetworkParams
from scribbleseg_core.optimize import SegmentParams, TrainedModel
from scribbleseg_core.patch_features import PatchEncoder
from scribbleseg_core.propagate import PropagateParams
from scribbleseg_core.refine import RefineParams

FORMAT = "scribbleseg-model"
VERSION = 1


def save_model(folder: str | os.PathLike, model: TrainedModel) -> Path:
    """Write `model` into `folder` (created if needed); each file atomically."""
    import torch

    folder = Path(folder)
    clf, enc = model.classifier, model.encoder
    buf = io.BytesIO()
    torch.save(clf.net.state_dict(), buf)
    arrays = io.BytesIO()
    np.savez(arrays, lo=enc.lo, hi=enc.hi, hks_mean=enc.hks_mean, hks_std=enc.hks_std,
             codebook=enc.codebook, mean=clf.mean, std=clf.std)
    meta = {
        "format": FORMAT,
        "version": VERSION,
        "scribbleseg": __version__,
        "feature_version": FEATURE_VERSION,
        "label_names": list(model.label_names),
        "num_inputs": clf.num_inputs,
        "delta": model.delta,
        "bins": enc.bins,
        "smooth": enc.smooth,
        "params": dataclasses.asdict(model.params),
    }
    atomic_write_bytes(folder / "weights.pt", buf.getvalue())
    atomic_write_bytes(folder / "arrays.npz", arrays.getvalue())
    atomic_write_text(folder / "model.json", json.dumps(meta, indent=1) + "\n")
    return folder


def load_model(folder: str | os.PathLike, *, expected_labels: list[str] | tuple[str, ...] | None = None) -> TrainedModel:
    """Read a model folder written by :func:`save_model`.

    Parameters
    ----------
    folder : str or os.PathLike
    expected_labels : sequence of str, optional
        Refuse a model trained on another label set.

    Raises
    ------
    ModelFileError
        Missing files, not our format, another version or feature version, another label
        set, or weights that do not fit the described network.
    """
    import torch

    folder = Path(folder)
    meta_path = folder / "model.json"
    if not meta_path.is_file():
        raise ModelFileError("not a scribbleseg model folder (no model.json)", folder)
    try:
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ModelFileError(f"unreadable model.json ({e})", meta_path) from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise ModelFileError(f"not a scribbleseg model (format {meta.get('format') if isinstance(meta, dict) else None!r})", meta_path)
    if meta.get("version") != VERSION:
        raise ModelFileError(f"model format version {meta.get('version')!r}; this scribbleseg reads version {VERSION}", meta_path)
    if meta.get("feature_version") != FEATURE_VERSION:
        raise ModelFileError(
            f"trained on feature version {meta.get('feature_version')!r}, this scribbleseg computes "
            f"version {FEATURE_VERSION}: retrain the model",
            meta_path,
        )
    names = tuple(meta.get("label_names") or ())
    if expected_labels is not None and tuple(expected_labels) != names:
        raise ModelFileError(
            f"trained on labels {list(names)}, but this collection uses {list(expected_labels)}", meta_path
        )
    try:
        p = meta["params"]
        net = NetworkParams(**{**p["network"], "hidden": tuple(p["network"]["hidden"])})
        # files from before cross-fitting (and its repeats) and the local shape ran without them
        params = SegmentParams(**{"cross_fit": 0.0, "cross_fit_repeats": 1, "local_shape": False, **p, "network": net, "refinement": RefineParams(**p["refinement"]),
                                  "propagation": _propagate_params(p.get("propagation", {})),
                                  "cores": _core_params(p), "context_scales": tuple(p["context_scales"])})
        with np.load(folder / "arrays.npz", allow_pickle=False) as z:
            arr = {key: z[key] for key in z.files}
        state = torch.load(folder / "weights.pt", map_location="cpu", weights_only=True)
        clf = FaceClassifier(int(meta["num_inputs"]), len(names), net)
        clf.net.load_state_dict(state)
        clf.mean, clf.std, clf.trained = arr["mean"], arr["std"], True
        encoder = PatchEncoder(arr["lo"], arr["hi"], arr["hks_mean"], arr["hks_std"], arr["codebook"],
                               int(meta["bins"]), float(meta["smooth"]))
    except FileNotFoundError as e:
        raise ModelFileError(f"incomplete model: {Path(e.filename).name} is missing", folder) from None
    except Exception as e:  # wrong shapes, a pickle, truncated files: all "not a model of ours"
        raise ModelFileError(f"corrupt or foreign model files ({type(e).__name__}: {e})"[:300], folder) from None
    scales = len(params.context_scales)
    expected = NUM_FEATURES * (1 + scales) + (LOCAL_SHAPE_PER_SCALE * scales if params.local_shape else 0)
    if clf.num_inputs != expected or clf.mean.shape != (expected,):
        raise ModelFileError(f"expects {clf.num_inputs} inputs per face, its parameters give {expected}", folder)
    return TrainedModel(clf, encoder, float(meta["delta"]), names, params)


def _core_params(p: dict) -> CoreParams | None:
    """The saved ``cores`` parameters; a model saved before they existed gets the defaults."""
    if "cores" not in p:
        return CoreParams()
    c = p["cores"]
    if c is None:
        return None
    return CoreParams(**{**c, "propagation": _propagate_params(c["propagation"])})


def _propagate_params(d: dict) -> PropagateParams:
    """Saved propagation parameters; files from before the random-walk term ran without it,
    and those from before the convex-crease weight used the dual graph's default."""
    return PropagateParams(**{"walk": 0.0, "convex": CONVEX_FACTOR, **d})
