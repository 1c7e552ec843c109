"""Save and load trained models as plain files that cannot execute code on load.

A model folder holds three files, and a fourth with a boundary classifier:

``model.json``
    The schema, version :data:`VERSION`::

        format          "scribbleseg-model"
        version         7
        scribbleseg     the package version that wrote it (informational)
        feature_version the per-face signatures' definition it was trained on
        label_names     k names
        network         {"num_inputs", "hidden", "dropout"}: the first stage's architecture
        inputs          {"context_scales", "local_shape"}: what the first stage reads per face
        label_context   true when the learner has its second stage (same widths; it reads
                        num_inputs + 2k values per face)
        prediction      {"method", "propagation", "lam"}: the energy of the graph cut on new
                        shapes (and of the app's preview)
        patches         {"bins", "smooth", "delta"}, method "paper" only (else null): the
                        patch descriptors and the feature term
        boundary        {"num_inputs"} of the learned boundary term, or null without one

    Nothing else is read: training-only settings are not stored.
``weights.pt``
    ``{"stage1": state dict, "stage2": state dict}`` (stage 2 only with label context), torch
    tensors read with ``weights_only=True``.
``arrays.npz``
    Input standardization of each stage (``mean``, ``std``; ``context_mean``,
    ``context_std``) and, method "paper" only, the patch encoder's ranges and codebook; read
    with ``allow_pickle=False``.
``boundary.txt``
    The learned boundary term (:class:`~scribbleseg_core.engine.boundary.BoundaryClassifier`):
    LightGBM's text model, parsed, never executed.

Any change to what prediction needs bumps :data:`VERSION`; files of another version are
refused with both versions named (retrain to get a current file).
"""

from __future__ import annotations

import dataclasses
import io
import json
import os
from pathlib import Path

import numpy as np

from scribbleseg_core import __version__
from scribbleseg_core.engine.boundary import BoundaryClassifier
from scribbleseg_core.engine.learner import Learner
from scribbleseg_core.engine.network import FaceClassifier, NetworkParams
from scribbleseg_core.engine.optimize import SegmentParams, TrainedModel
from scribbleseg_core.engine.patch_features import PatchEncoder
from scribbleseg_core.engine.propagate import PropagateParams
from scribbleseg_core.engine.shape import network_input_width
from scribbleseg_core.errors import ModelFileError
from scribbleseg_core.infra.atomic import atomic_write_bytes, atomic_write_text
from scribbleseg_core.signatures.features import FEATURE_VERSION

FORMAT = "scribbleseg-model"
#: The schema version this scribbleseg writes and reads.
VERSION = 7


def save_model(folder: str | os.PathLike, model: TrainedModel) -> Path:
    """Write `model` into `folder` (created if needed); each file atomically, ``model.json`` last."""
    import torch

    folder = Path(folder)
    clf, second, enc, p = model.learner.stage1, model.learner.stage2, model.encoder, model.params
    buf = io.BytesIO()
    states = {"stage1": clf.net.state_dict()}
    extra = {}
    if second is not None:
        states["stage2"] = second.net.state_dict()
        extra = dict(context_mean=second.mean, context_std=second.std)
    torch.save(states, buf)
    arrays = io.BytesIO()
    encoder = {} if enc is None else dict(lo=enc.lo, hi=enc.hi, hks_mean=enc.hks_mean, hks_std=enc.hks_std,
                                          codebook=enc.codebook)
    np.savez(arrays, mean=clf.mean, std=clf.std, **extra, **encoder)
    meta = {
        "format": FORMAT,
        "version": VERSION,
        "scribbleseg": __version__,
        "feature_version": FEATURE_VERSION,
        "label_names": list(model.label_names),
        "network": {"num_inputs": clf.num_inputs, "hidden": list(clf.params.hidden), "dropout": clf.params.dropout},
        "inputs": {"context_scales": list(p.context_scales), "local_shape": p.local_shape},
        "label_context": second is not None,
        "prediction": {"method": p.method, "propagation": dataclasses.asdict(p.propagation), "lam": p.lam},
        "patches": None if enc is None else {"bins": enc.bins, "smooth": enc.smooth, "delta": model.delta},
        "boundary": None if model.boundary is None else {"num_inputs": model.boundary.num_inputs},
    }
    if model.boundary is not None:
        atomic_write_text(folder / "boundary.txt", model.boundary.to_text())
    else:
        (folder / "boundary.txt").unlink(missing_ok=True)  # an earlier model's, over which this one is saved
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

    Returns
    -------
    TrainedModel
        Its ``params`` hold the stored prediction settings; training-only settings are
        the defaults.

    Raises
    ------
    ModelFileError
        Missing files, not our format, another schema or feature version, another label
        set, or weights that do not fit the described network.
    """
    folder = Path(folder)
    meta = _read_meta(folder)
    names = tuple(meta.get("label_names") or ())
    if expected_labels is not None and tuple(expected_labels) != names:
        raise ModelFileError(
            f"trained on labels {list(names)}, but this collection uses {list(expected_labels)}", folder
        )
    try:
        net, inputs, pred, patches, edges = (meta[key] for key in ("network", "inputs", "prediction", "patches",
                                                                    "boundary"))
        network = dataclasses.replace(NetworkParams(), hidden=tuple(net["hidden"]), dropout=float(net["dropout"]))
        params = SegmentParams(
            method=pred["method"],
            lam=float(pred["lam"]),
            context_scales=tuple(float(t) for t in inputs["context_scales"]),
            local_shape=bool(inputs["local_shape"]),
            label_context=_flag(meta["label_context"]),
            network=network,
            propagation=PropagateParams(**pred["propagation"]),
        )
        num_inputs = int(net["num_inputs"])
        if params.method == "paper":
            delta, bins, smooth = float(patches["delta"]), int(patches["bins"]), float(patches["smooth"])
    except (KeyError, TypeError) as e:
        missing = f"lacks {e}" if isinstance(e, KeyError) else f"does not fit ({e})"
        raise ModelFileError(f"model.json {missing}; model format {VERSION} requires it"[:300], folder) from None
    except ValueError as e:
        raise ModelFileError(f"model.json does not fit model format {VERSION} ({e})"[:300], folder) from None
    try:
        learner, arr = _read_arrays(folder, num_inputs, len(names), network, params.label_context)
        encoder = None
        if params.method == "paper":
            encoder = PatchEncoder(arr["lo"], arr["hi"], arr["hks_mean"], arr["hks_std"], arr["codebook"], bins, smooth)
        boundary = None
        if edges is not None:
            boundary = BoundaryClassifier.from_text((folder / "boundary.txt").read_text(encoding="utf-8"))
            if boundary.num_inputs != int(edges["num_inputs"]):
                raise ValueError(f"boundary.txt reads {boundary.num_inputs} values per edge, model.json says "
                                 f"{edges['num_inputs']}")
    except FileNotFoundError as e:
        raise ModelFileError(f"incomplete model: {Path(e.filename).name} is missing", folder) from None
    except Exception as e:  # wrong shapes, a pickle, truncated files: all "not a model of ours"
        raise ModelFileError(f"corrupt or foreign model files ({type(e).__name__}: {e})"[:300], folder) from None
    expected = network_input_width(len(params.context_scales), params.local_shape)
    clf = learner.stage1
    if clf.num_inputs != expected or clf.mean.shape != (expected,):
        raise ModelFileError(f"expects {clf.num_inputs} inputs per face, its parameters give {expected}", folder)
    return TrainedModel(learner, names, params, encoder, delta if encoder is not None else None, boundary=boundary)


def _read_meta(folder: Path) -> dict:
    """``model.json`` of `folder`, checked for format, schema version and feature version."""
    meta_path = folder / "model.json"
    if not meta_path.is_file():
        raise ModelFileError("not a scribbleseg model folder (no model.json)", folder)
    try:
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ModelFileError(f"unreadable model.json ({e})", meta_path) from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise ModelFileError(f"not a scribbleseg model (format {meta.get('format') if isinstance(meta, dict) else None!r})", meta_path)
    version = meta.get("version")
    if version != VERSION:
        writer = f", written by scribbleseg {meta['scribbleseg']}" if isinstance(meta.get("scribbleseg"), str) else ""
        if isinstance(version, int) and version < VERSION:
            raise ModelFileError(f"model format version {version}{writer}, older than the version {VERSION} this "
                                 f"scribbleseg reads: train the model again", folder)
        raise ModelFileError(f"model format version {version!r}{writer}; this scribbleseg reads version {VERSION}: "
                             f"use the scribbleseg that wrote it, or train the model again", folder)
    if meta.get("feature_version") != FEATURE_VERSION:
        raise ModelFileError(
            f"trained on feature version {meta.get('feature_version')!r}, this scribbleseg computes "
            f"version {FEATURE_VERSION}: train the model again",
            folder,
        )
    return meta


def _flag(value) -> bool:
    if not isinstance(value, bool):
        raise ValueError(f"label_context must be true or false, not {value!r}")
    return value


def _read_arrays(folder: Path, num_inputs: int, k: int, network: NetworkParams,
                 label_context: bool) -> tuple[Learner, dict]:
    """The learner (weights, standardization) of `folder`, and every array of ``arrays.npz``."""
    import torch

    with np.load(folder / "arrays.npz", allow_pickle=False) as z:
        arr = {key: z[key] for key in z.files}
    states = torch.load(folder / "weights.pt", map_location="cpu", weights_only=True)
    if not isinstance(states, dict) or set(states) != ({"stage1", "stage2"} if label_context else {"stage1"}):
        raise ValueError("weights.pt does not hold the stages model.json describes")

    def stage(num, state, mean, std) -> FaceClassifier:
        clf = FaceClassifier(num, k, network)
        clf.net.load_state_dict(state)
        clf.mean, clf.std, clf.trained = arr[mean], arr[std], True
        if clf.mean.shape != (num,) or clf.std.shape != (num,):
            raise ValueError(f"standardization of {mean} has shape {clf.mean.shape}, expected ({num},)")
        return clf

    first = stage(num_inputs, states["stage1"], "mean", "std")
    second = stage(num_inputs + 2 * k, states["stage2"], "context_mean", "context_std") if label_context else None
    return Learner(first, second), arr
