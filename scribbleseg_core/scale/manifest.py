"""What a batch job has written into its output folder, so a rerun does only what is missing.

``OUT/manifest.jsonl`` holds one JSON object per finished shape, appended as each finishes
(a later line for the same key wins; a truncated last line, from a job killed mid-write, is
ignored):

``{"key": "chairs/101", "source": "/data/chairs/101.off", "size": 123456, "mtime_ns": ...,
"job": "<fingerprint>", "outputs": ["chairs/101.seg", "chairs/101.ply"]}``

A shape is done when its line names the present job fingerprint (the model's files and the
prediction settings, :func:`job_fingerprint`), its source still has the recorded size and
modification time, and every output it lists exists.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

from scribbleseg_core.infra.atomic import atomic_write_text
from scribbleseg_core.scale.inputs import Source

MANIFEST_NAME = "manifest.jsonl"
#: The files of a model folder that decide its predictions (:mod:`scribbleseg_core.store.model_file`).
MODEL_FILES = ("model.json", "weights.pt", "arrays.npz", "boundary.txt")


def job_fingerprint(model_folder: str | os.PathLike, settings: dict) -> str:
    """SHA-256 (hex, 16 digits) of the model folder's files and the prediction `settings`."""
    h = hashlib.sha256()
    for name in MODEL_FILES:
        path = Path(model_folder) / name
        h.update(name.encode())
        h.update(path.read_bytes() if path.exists() else b"")
    h.update(json.dumps(settings, sort_keys=True).encode())
    return h.hexdigest()[:16]


def source_stamp(path: Path) -> dict:
    """Size and modification time of a source file, as the manifest records them."""
    st = path.stat()
    return {"size": st.st_size, "mtime_ns": st.st_mtime_ns}


class Manifest:
    """The manifest of one output folder.

    Parameters
    ----------
    out : Path
        The output folder (created by the caller).
    """

    def __init__(self, out: Path):
        self.out = out
        self.path = out / MANIFEST_NAME
        self.entries: dict[str, dict] = {}
        if self.path.exists():
            for line in self.path.read_text(encoding="utf-8", errors="replace").splitlines():
                try:
                    entry = json.loads(line)
                    self.entries[entry["key"]] = entry
                except (json.JSONDecodeError, KeyError, TypeError):
                    continue  # a line cut short by a killed job

    def compact(self) -> None:
        """Rewrite the file atomically with one line per key (dropping cut lines and older
        lines of the same key)."""
        if self.path.exists() or self.entries:
            atomic_write_text(self.path, "".join(json.dumps(e) + "\n" for e in self.entries.values()))

    def is_done(self, source: Source, job: str) -> bool:
        """Are `source`'s outputs in place, from this job fingerprint and this version of the file?"""
        entry = self.entries.get(source.key)
        if entry is None or entry.get("job") != job or entry.get("source") != os.fspath(source.path.resolve()):
            return False
        try:
            if {k: entry.get(k) for k in ("size", "mtime_ns")} != source_stamp(source.path):
                return False
        except OSError:
            return False
        return all((self.out / name).exists() for name in entry.get("outputs", ()))

    def record(self, source: Source, job: str, outputs: list[str]) -> None:
        """Append `source` as done (after its outputs were written); flushed to disk at once."""
        entry = {"key": source.key, "source": os.fspath(source.path.resolve()), **source_stamp(source.path),
                 "job": job, "outputs": outputs}
        self.entries[source.key] = entry
        with open(self.path, "a", encoding="utf-8") as f:
            f.write(json.dumps(entry) + "\n")
            f.flush()
            os.fsync(f.fileno())
