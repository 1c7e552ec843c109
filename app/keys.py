"""Every key of the app, in one table: the window's shortcuts, the keys pressed in the viewport's
window, and the *Help → Keys* sheet all read it. No Qt here."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Key:
    """One key.

    Attributes
    ----------
    keys : str
        As Qt's ``QKeySequence`` reads it (``"Ctrl+Shift+Z"``).
    imgui : str or None
        The ``ImGuiKey_`` name of the same key in the viewport's window (modifiers from `keys`);
        None: the viewport window does not take it.
    command : str
        What :meth:`MainWindow.command` does.
    text : str
        What the sheet says.
    """

    keys: str
    imgui: str | None
    command: str
    text: str

    @property
    def ctrl(self) -> bool:
        return "Ctrl+" in self.keys

    @property
    def shift(self) -> bool:
        return "Shift+" in self.keys


KEYS: tuple[Key, ...] = (
    *(Key(str(k), str(k), f"label {k - 1}", f"paint with label {k}") for k in range(1, 10)),
    Key("E", "E", "eraser", "eraser on or off"),
    Key("B", "B", "tool brush", "brush: paint the faces under a round brush, measured along the surface"),
    Key("F", "F", "tool fill", "fill: a click paints the whole region around it (bounded by creases or labels)"),
    Key("P", "P", "paint", "paint mode on or off (off: the left drag turns the camera)"),
    Key("[", "LeftBracket", "brush -", "smaller brush"),
    Key("]", "RightBracket", "brush +", "larger brush"),
    Key("Ctrl+Z", "Z", "undo", "undo the last stroke or fill"),
    Key("Ctrl+Shift+Z", "Z", "redo", "redo"),
    Key("H", "H", "hide label", "hide or show the current label"),
    Key("O", "O", "only current", "show only the current label, or every label"),
    Key("C", "C", "confidence", "show the confidence of the last run, or the labels"),
    Key("V", "V", "next view", "next Show mode (labels, scribbles, result, confidence, signatures)"),
    Key("Shift+V", "V", "previous view", "previous Show mode"),
    Key("N", "N", "suggestion", "go to the unsure region that weighs most on its shape (after a run)"),
    Key("A", "A", "accept", "accept the current shape's result as its labels (then correct it)"),
    Key("PgDown", "PageDown", "next shape", "next shape"),
    Key("PgUp", "PageUp", "previous shape", "previous shape"),
    Key("Ctrl+R", "R", "segment", "segment the collection"),
    Key("F1", "F1", "keys", "this sheet"),
)


def sheet() -> list[tuple[str, str]]:
    """(keys, what they do) rows for the *Help → Keys* sheet; the label keys as one row."""
    rows = [("1 – 9", "paint with that label")]
    rows += [(k.keys, k.text) for k in KEYS if not k.command.startswith("label ")]
    return rows
