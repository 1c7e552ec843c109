"""Label names and colors shared by the viewport, the panels and every export."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Color of faces with no label (-1), RGB in [0, 1].
UNLABELED_COLOR = (0.62, 0.62, 0.62)

# A qualitative palette (ColorBrewer Set1/Dark2/Paired mix), distinct on gray surfaces.
_PALETTE = np.array(
    [
        [228, 26, 28], [55, 126, 184], [77, 175, 74], [152, 78, 163], [255, 127, 0],
        [255, 221, 51], [166, 86, 40], [247, 129, 191], [27, 158, 119], [102, 166, 30],
        [117, 112, 179], [230, 171, 2], [31, 120, 180], [251, 154, 153], [178, 223, 138],
        [202, 178, 214], [253, 191, 111], [106, 61, 154], [177, 89, 40], [0, 0, 128],
    ],
    dtype=np.float64,
) / 255.0


def default_color(index: int) -> tuple[float, float, float]:
    """The palette color for label `index` (cycles with a shift past 20 labels)."""
    base = _PALETTE[index % len(_PALETTE)]
    shade = 1.0 - 0.25 * ((index // len(_PALETTE)) % 3)
    return tuple(float(c) for c in base * shade)


@dataclass(frozen=True)
class LabelSet:
    """Ordered label names with their colors.

    Attributes
    ----------
    names : tuple of str
        ``names[i]`` is the name of label id ``i``.
    colors : (k, 3) float64 ndarray
        RGB in [0, 1].
    """

    names: tuple[str, ...]
    colors: np.ndarray

    @classmethod
    def from_names(cls, names, colors=None) -> LabelSet:
        names = tuple(str(n) for n in names)
        if colors is None:
            colors = [default_color(i) for i in range(len(names))]
        colors = np.asarray(colors, dtype=np.float64).reshape(-1, 3)
        if colors.shape[0] != len(names):
            raise ValueError(f"{len(names)} label names but {colors.shape[0]} colors")
        if colors.size and (not np.isfinite(colors).all() or colors.min() < 0 or colors.max() > 1):
            raise ValueError("label colors must be RGB values in [0, 1]")
        return cls(names, colors)

    def __len__(self) -> int:
        return len(self.names)

    def face_colors(self, labels: np.ndarray) -> np.ndarray:
        """Per-face RGB for `labels` (m,) int; -1 (unlabeled) gets the neutral gray.

        Returns
        -------
        C : (m, 3) float64 ndarray
        """
        labels = np.asarray(labels, dtype=np.int64)
        table = np.vstack([self.colors, UNLABELED_COLOR]) if len(self) else np.array([UNLABELED_COLOR])
        idx = np.where((labels >= 0) & (labels < len(self)), labels, len(self))
        return table[idx]

    def to_json(self) -> dict:
        return {
            "label_names": list(self.names),
            "label_colors": [[round(float(c), 6) for c in row] for row in self.colors],
        }
