"""The main window: it composes the panels and the controllers and wires them together.

What the app does lives in the controllers (:mod:`scribbleseg_app.controllers`, no Qt), what it
shows in the panels (:mod:`scribbleseg_app.widgets`); this module holds the menus, the dialogs,
the frame timer and the hop of background results onto this thread.
"""

from __future__ import annotations

import gc
from pathlib import Path

import numpy as np
from PySide6.QtCore import QObject, Qt, QTimer, Signal
from PySide6.QtGui import QAction, QColor, QKeySequence, QShortcut
from PySide6.QtWidgets import (
    QColorDialog,
    QDialog,
    QDialogButtonBox,
    QFileDialog,
    QInputDialog,
    QMainWindow,
    QMessageBox,
    QTableWidget,
    QTableWidgetItem,
    QVBoxLayout,
    QWidget,
)
from scribbleseg_app.controllers.files import FilesController
from scribbleseg_app.controllers.frames import FrameClock
from scribbleseg_app.controllers.jobs import Dispatcher
from scribbleseg_app.controllers.preview import PreviewController
from scribbleseg_app.controllers.run import RunController
from scribbleseg_app.controllers.tools import FILL_BOUNDS, ToolsController
from scribbleseg_app.controllers.view import SHOW_MODES, ViewController
from scribbleseg_app.keys import KEYS, sheet
from scribbleseg_app.model import CollectionModel
from scribbleseg_app.widgets.panels import LabelsPanel, RunPanel, ShapesPanel, ToolsPanel

from scribbleseg_core import __version__
from scribbleseg_core.infra.user_dirs import default_state_dir

#: Default collection when none is given: the bundled demo creatures.
DEFAULT_COLLECTION = Path(__file__).resolve().parents[1] / "assets" / "Quadruped"
#: The frame timer's period (ms); :class:`FrameClock` decides which ticks render.
TICK_MS = 16


class QtDispatcher(QObject, Dispatcher):
    """Posts calls onto the thread this object lives in (the main thread), queued."""

    _call = Signal(object)

    def __init__(self, parent=None):
        super().__init__(parent)
        self._call.connect(self._run, Qt.ConnectionType.QueuedConnection)

    def post(self, fn) -> None:
        self._call.emit(fn)

    @staticmethod
    def _run(fn) -> None:
        fn()


def warm_imports() -> None:
    """Import the engine's heavy modules now, on the main thread, and freeze what they made
    (``gc.freeze``). Imported first inside a worker, torch alone holds the interpreter for
    about a second, and the viewport freezes mid-run."""
    import maxflow  # noqa: F401
    import potpourri3d  # noqa: F401
    import scipy.sparse.linalg  # noqa: F401
    import torch  # noqa: F401

    import scribbleseg_core.engine.optimize  # noqa: F401
    import scribbleseg_core.engine.pipeline  # noqa: F401

    # What the imports made lives as long as the app: out of the collector's reach, a full
    # collection no longer walks it (a stalled frame at a random moment otherwise).
    gc.freeze()


class MainWindow(QMainWindow):
    """Top-level window; the viewport is polyscope's own window (it cannot be embedded).

    Parameters
    ----------
    path : str, optional
        A collection folder, one mesh, or a session folder; default :data:`DEFAULT_COLLECTION`.
    viewport : PolyscopeViewport, optional
        Made on first use when not given (tests pass their own).
    autosave_dir : str, optional
        Where scribbles are saved after every stroke; default the user state folder.

    Attributes
    ----------
    model : CollectionModel
    view, runs, previews, files, toolbox : the controllers
    shapes, labels, tools, run_panel : the panels
    frames : FrameClock
    """

    def __init__(self, path: str | None = None, viewport=None, autosave_dir=None):
        super().__init__()
        warm_imports()
        self.setWindowTitle(f"scribbleseg {__version__}")
        self.resize(460, 820)
        if autosave_dir is None:
            autosave_dir = default_state_dir() / "autosave"
        self.model = m = CollectionModel(autosave_dir)
        self.dispatcher = QtDispatcher(self)
        self.previews = PreviewController(m, self.dispatcher)
        self.frames = FrameClock(waiting=lambda: not self.previews.idle)
        self.toolbox = ToolsController(m, self.dispatcher)
        self._viewport = None
        if viewport is not None:
            self._attach(viewport)
        self.view = ViewController(m, self.dispatcher, lambda: self.viewport)
        self.runs = RunController(m, self.dispatcher)
        self.files = FilesController(m, self.dispatcher)
        self.shapes = ShapesPanel(m, self.runs)
        self.labels = LabelsPanel(m, self.view)
        self.tools = ToolsPanel()
        self.run_panel = RunPanel(self.runs)
        panel = QWidget()
        layout = QVBoxLayout(panel)
        layout.addWidget(self.shapes, 3)
        layout.addWidget(self.labels, 2)
        layout.addWidget(self.tools)
        layout.addWidget(self.run_panel)
        self.setCentralWidget(panel)
        self._quitting = False  # set once the user chose to quit (skips the unsaved-work question)
        self._placed = False
        self._focus_on = None  # a suggestion to turn the camera to once its shape is shown
        self._build_menus()
        self._connect()
        self.timer = QTimer(self)
        self.timer.timeout.connect(self._on_tick)
        self.timer.start(TICK_MS)
        m.open(path or DEFAULT_COLLECTION)

    # ---------------------------------------------------------------- wiring

    def _build_menus(self) -> None:
        app_wide = Qt.ShortcutContext.ApplicationShortcut  # one main window; text fields still take their keys
        self.undo_action = QAction("Undo", self, shortcut=QKeySequence.StandardKey.Undo, triggered=self.model.undo)
        self.redo_action = QAction("Redo", self, shortcut=QKeySequence("Ctrl+Shift+Z"), triggered=self.model.redo)
        file_menu = self.menuBar().addMenu("&File")
        for text, key, slot in (
            ("Open collection…", QKeySequence.StandardKey.Open, self._on_open_collection),
            ("Open session…", None, self._on_open_session),
            ("Add meshes…", None, self._on_add_meshes),
            ("Save session", QKeySequence.StandardKey.Save, self.save_session),
            ("Save session as…", QKeySequence.StandardKey.SaveAs, self._on_save_session_as),
            ("Export current shape…", None, self._on_export_current),
            ("Export all…", None, self._on_export),
            ("Quit", QKeySequence.StandardKey.Quit, self.close),  # asks about unsaved work first
        ):
            action = QAction(text, self, triggered=slot)
            if key is not None:
                action.setShortcut(key)
            file_menu.addAction(action)
        edit = self.menuBar().addMenu("&Edit")
        for action in (self.undo_action, self.redo_action):
            action.setShortcutContext(app_wide)
            edit.addAction(action)
        help_menu = self.menuBar().addMenu("&Help")
        help_menu.addAction(QAction("Keys", self, triggered=self.show_keys))
        for key in KEYS:  # undo and redo are the Edit menu's
            if key.command not in ("undo", "redo"):
                QShortcut(QKeySequence(key.keys), self, activated=lambda c=key.command: self.command(c), context=app_wide)

    def _connect(self) -> None:
        m, tools, labels, run = self.model, self.tools, self.labels, self.run_panel
        status = self.statusBar().showMessage
        # the panel is narrow and long messages are cut: hovering the status bar shows all of it
        self.statusBar().messageChanged.connect(self.statusBar().setToolTip)
        labels.list.currentRowChanged.connect(self._on_label_row)
        labels.list.itemDoubleClicked.connect(lambda item: self._on_rename(labels.list.row(item)))
        labels.add_button.clicked.connect(self._on_add_label)
        labels.color_button.clicked.connect(self._on_recolor)
        labels.delete_button.clicked.connect(self._on_delete_label)
        tools.show_combo.currentTextChanged.connect(self.view.set_mode)
        tools.paint_box.toggled.connect(lambda on: setattr(self.viewport, "paint_mode", on))
        tools.paint_box.toggled.connect(lambda on: on or self.toolbox.clear_highlight())
        tools.brush_radio.toggled.connect(lambda on: on and self.toolbox.set_tool("brush"))
        tools.fill_radio.toggled.connect(lambda on: on and self.toolbox.set_tool("fill"))
        tools.fill_bound_combo.currentIndexChanged.connect(
            lambda i: self.toolbox.set_fill_bound(FILL_BOUNDS[i]))
        tools.crease_slider.valueChanged.connect(lambda v: self.toolbox.set_crease(v / 10.0))
        tools.eraser_box.toggled.connect(lambda on: m.set_current_label(-1 if on else max(labels.list.currentRow(), 0)))
        tools.brush_slider.valueChanged.connect(lambda v: m.set_brush_radius(v / 1000.0))
        tools.preview_box.toggled.connect(self._on_preview_toggled)
        run.run_button.clicked.connect(lambda: self._report(self.runs.segment()))
        run.stop_button.clicked.connect(self.runs.stop)
        run.predict_button.clicked.connect(lambda: self._report(self.runs.predict()))
        run.export_button.clicked.connect(self._on_export)
        run.accept_button.clicked.connect(self.accept_current)
        run.suggest_button.clicked.connect(self.go_to_suggestion)
        self.toolbox.highlight_changed.connect(self.view.set_highlight)
        self.toolbox.status.connect(status)
        self.view.shown.connect(self._on_shown)
        m.suggestion_changed.connect(self._on_suggestion)
        self.runs.started.connect(self._on_run_started)
        self.runs.step.connect(lambda snap: status(f"round {snap.iteration}: {snap.phase} ({snap.seconds:.1f} s)"))
        self.runs.finished.connect(self._on_run_finished)
        self.previews.done.connect(lambda i, s: status(f"{m.shapes[i].name}: preview in {s * 1000:.0f} ms"))
        self.previews.failed.connect(status)
        self.view.status.connect(status)
        self.files.saved.connect(self._on_saved)
        self.files.exported.connect(lambda folder, files: status(f"exported {len(files)} files to {folder}"))
        self.files.failed.connect(self._on_error)
        m.collection_changed.connect(self._on_collection_changed)
        m.unsaved_changed.connect(lambda _unsaved: self._update_title())
        m.shapes_added.connect(lambda idx: status(f"added {len(idx)} shapes; 'Predict unlabeled' segments them"))
        m.restore_available.connect(lambda n: QTimer.singleShot(0, lambda: self._offer_restore(n)))
        m.error.connect(self._on_error)
        for event in (m.scribbles_changed, m.result_changed, m.current_changed, m.labels_changed):
            event.connect(lambda *_: self.frames.wake())

    @property
    def viewport(self):
        if self._viewport is None:
            from scribbleseg_app.viewport import PolyscopeViewport

            self._attach(PolyscopeViewport())
        return self._viewport

    def _attach(self, viewport) -> None:
        """Make `viewport` this window's: its strokes go to this window's model."""
        self._viewport = viewport
        viewport.paint_mode = False
        viewport.set_paint_handlers(self.toolbox.begin, self.toolbox.at, self.toolbox.end)
        viewport.set_key_handler(self._on_viewport_key)
        viewport.set_hover_handler(self._on_hover)

    # ---------------------------------------------------------------- labels and brush

    def _grow_brush(self, step: int) -> None:
        self.tools.brush_slider.setValue(self.tools.brush_slider.value() + step)

    def _on_viewport_key(self, command: str) -> None:
        """The same keys as the window's shortcuts, pressed in polyscope's window."""
        self.command(command)

    def command(self, command: str) -> None:
        """Do what a key of :data:`~scribbleseg_app.keys.KEYS` says."""
        m, tools = self.model, self.tools
        if command == "undo":
            m.undo()
        elif command == "redo":
            m.redo()
        elif command.startswith("label "):
            self.choose_label(int(command.split()[1]))
        elif command in ("brush -", "brush +"):
            self._grow_brush(-5 if command == "brush -" else 5)
        elif command == "eraser":
            tools.eraser_box.toggle()
        elif command == "tool brush":
            tools.brush_radio.setChecked(True)
        elif command == "tool fill":
            tools.fill_radio.setChecked(True)
        elif command == "paint":
            tools.paint_box.toggle()
        elif command == "hide label":
            self.labels.toggle_visible(self.labels.list.currentRow())
        elif command == "only current":
            self.labels.only_box.toggle()
        elif command == "confidence":
            mode = SHOW_MODES[0] if tools.show_combo.currentText() == "Confidence" else "Confidence"
            tools.show_combo.setCurrentText(mode)
        elif command in ("next view", "previous view"):
            step = 1 if command == "next view" else -1
            tools.show_combo.setCurrentIndex((tools.show_combo.currentIndex() + step) % tools.show_combo.count())
        elif command == "suggestion":
            self.go_to_suggestion()
        elif command == "accept":
            self.accept_current()
        elif command in ("next shape", "previous shape") and m.shapes:
            rows = self.shapes.order
            row = rows.index(m.current) if m.current in rows else 0
            m.set_current(rows[(row + (1 if command == "next shape" else -1)) % len(rows)])
        elif command == "segment":
            self._report(self.runs.segment())
        elif command == "keys":
            self.show_keys()

    def show_keys(self) -> None:
        """*Help → Keys*: every key and what it does."""
        rows = sheet()
        dialog = QDialog(self)
        dialog.setWindowTitle("Keys")
        table = QTableWidget(len(rows), 2, dialog)
        table.setHorizontalHeaderLabels(["Key", "Does"])
        for r, (key, text) in enumerate(rows):
            table.setItem(r, 0, QTableWidgetItem(key))
            table.setItem(r, 1, QTableWidgetItem(text))
        table.verticalHeader().setVisible(False)
        table.horizontalHeader().setStretchLastSection(True)
        table.resizeColumnsToContents()
        table.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
        close = QDialogButtonBox(QDialogButtonBox.StandardButton.Close, dialog)
        close.rejected.connect(dialog.close)
        layout = QVBoxLayout(dialog)
        layout.addWidget(table)
        layout.addWidget(close)
        dialog.resize(640, 560)
        dialog.setModal(False)
        dialog.show()
        dialog.activateWindow()  # Escape closes it
        self.keys_dialog = dialog

    # ---------------------------------------------------------------- guidance

    def accept_current(self) -> None:
        """Accept the current shape's result as its labels (key A)."""
        m = self.model
        if m.current < 0:
            return
        n = m.accept(m.current)
        if n:
            self.statusBar().showMessage(f"{m.shapes[m.current].name}: accepted ({n} faces labeled); correct it with "
                                         "the brush or the fill, and the next run trains on it")
        else:
            self.statusBar().showMessage("nothing to accept: this shape has no result, or every face is painted")

    def go_to_suggestion(self) -> None:
        """Show the shape and turn the camera to the unsure region that weighs most on it (key N)."""
        s = self.model.suggestion
        if s is None:
            self.statusBar().showMessage("no suggestion: run 'Segment collection' first (or every face is confident)")
            return
        self._focus_on = s
        if self.model.current != s.index:
            self.model.set_current(s.index)  # focused once shown
        elif self.view.showing == s.index:
            self._on_shown(s.index)

    def _on_shown(self, index: int) -> None:
        s = self._focus_on
        if s is None or s.index != index or self._viewport is None:
            return
        self._focus_on = None
        mesh = self.model.shapes[index].mesh()
        tri = mesh.V_file[mesh.F_file[s.face]]
        self.viewport.focus(tri.mean(axis=0), np.cross(tri[1] - tri[0], tri[2] - tri[0]))
        self.statusBar().showMessage(f"{mesh.name}: paint in the hatched region ({len(s.faces)} unsure faces)")

    def _on_suggestion(self) -> None:
        s = self.model.suggestion
        self.run_panel.suggest_button.setEnabled(s is not None)
        if s is not None:
            self.run_panel.suggest_button.setToolTip(f"{self.model.shapes[s.index].name}: a region of {len(s.faces)} "
                                                     "faces the network is unsure of")

    def choose_label(self, label: int) -> None:
        """Paint with `label` (the eraser goes off)."""
        if 0 <= label < self.labels.list.count():
            self.tools.eraser_box.setChecked(False)
            self.labels.list.setCurrentRow(label)

    def _on_label_row(self, row: int) -> None:
        if row >= 0 and not self.tools.eraser_box.isChecked():
            self.model.set_current_label(row)

    def _on_add_label(self) -> None:
        name, ok = QInputDialog.getText(self, "Add label", "Name of the new label:")
        if ok:
            try:
                k = self.model.add_label(name)
            except ValueError as e:
                self._on_error(str(e))
                return
            self.labels.list.setCurrentRow(k)

    def _on_rename(self, row: int) -> None:
        name, ok = QInputDialog.getText(self, "Rename label", "New name:", text=self.model.label_set.names[row])
        if ok:
            try:
                self.model.rename_label(row, name)
            except ValueError as e:
                self._on_error(str(e))

    def _on_recolor(self) -> None:
        row = self.labels.list.currentRow()
        if row < 0:
            return
        color = QColorDialog.getColor(QColor.fromRgbF(*self.model.label_set.colors[row]), self)
        if color.isValid():
            self.model.recolor_label(row, (color.redF(), color.greenF(), color.blueF()))

    def _on_delete_label(self) -> None:
        row = self.labels.list.currentRow()
        if row < 0:
            return
        name = self.model.label_set.names[row]
        if self._confirm("Delete label", f"Delete label '{name}'? Its scribbles are erased and its result faces unlabeled."):
            erased = self.model.delete_label(row)
            self.statusBar().showMessage(f"deleted '{name}' ({erased} scribbled faces erased)")

    def _on_preview_toggled(self, on: bool) -> None:
        self.previews.enabled = on
        if on and self.model.current >= 0:
            self.previews.request(self.model.current)

    def _on_hover(self, face: int) -> None:
        if self.tools.paint_box.isChecked():
            self.toolbox.hover(face)
        text = self.view.hover_text(face)
        if text:
            self.statusBar().showMessage(text)

    # ---------------------------------------------------------------- runs

    def _report(self, problem: str | None) -> None:
        if problem:
            self._on_error(problem)

    def _on_run_started(self, kind: str) -> None:
        # label ids must not change under a run: its results use the old ones
        for b in (self.labels.add_button, self.labels.delete_button):
            b.setEnabled(False)
        # A full garbage collection walks every object and stalls a frame: run it now, as the
        # run starts, and keep what survives out of the collector's reach until the next run
        # (its cycles are collected then).
        gc.unfreeze()
        gc.collect()
        gc.freeze()
        self.frames.busy = True
        self.frames.reset_gap()
        self.statusBar().showMessage("computing shape signatures…" if kind == "segmentation" else "predicting…")

    def _on_run_finished(self, message: str) -> None:
        for b in (self.labels.add_button, self.labels.delete_button):
            b.setEnabled(True)
        self.frames.busy = False
        if message.startswith("error: "):
            self._on_error(message[7:])
            return
        if "finished" in message:
            message += f" (longest frame gap {self.frames.max_gap * 1000:.0f} ms)"
        self.statusBar().showMessage(message)

    # ---------------------------------------------------------------- files

    def _on_collection_changed(self) -> None:
        self._update_title()
        self.statusBar().showMessage(f"{self.model.folder}: {len(self.model.shapes)} shapes")

    def _update_title(self) -> None:
        m = self.model
        where = m.session_path or m.folder
        self.setWindowTitle(f"scribbleseg {__version__}" + (f" — {where.name}" if where else "") + (" *" if m.unsaved else ""))

    def _on_open_collection(self) -> None:
        if not self.keep_unsaved_work():
            return
        folder = QFileDialog.getExistingDirectory(self, "Open a folder of meshes")
        if folder:
            self.model.open(folder)

    def _on_open_session(self) -> None:
        if not self.keep_unsaved_work():
            return
        folder = QFileDialog.getExistingDirectory(self, "Open a session folder")
        if folder:
            self.model.open_session(folder)

    def _on_add_meshes(self) -> None:
        paths, _ = QFileDialog.getOpenFileNames(self, "Add meshes", "", "Meshes (*.off *.obj *.ply *.stl *.glb *.gltf)")
        if paths:
            self.files.add_meshes(paths)
            self.statusBar().showMessage(f"reading {len(paths)} meshes…")

    def keep_unsaved_work(self, *, can_cancel: bool = True) -> bool:
        """Before the collection goes away: offer to save a session if there are unsaved
        changes (saved here, before returning). Returns False if the user cancelled (or the
        save failed): stay."""
        if not self.model.unsaved or not self.model.shapes:
            return True
        answer = self._ask_unsaved(can_cancel)
        if answer == "save":
            return self.save_session(wait=True) or not can_cancel
        return answer == "discard"

    def _ask_unsaved(self, can_cancel: bool) -> str:
        """'save', 'discard' or 'cancel' (tests replace this)."""
        buttons = QMessageBox.StandardButton.Save | QMessageBox.StandardButton.Discard
        if can_cancel:
            buttons |= QMessageBox.StandardButton.Cancel
        answer = QMessageBox.question(
            self, "Unsaved changes",
            "Save the results, labels and scribbles as a session?\n(Scribbles are autosaved either way "
            "and offered again when this collection is opened; results and label changes are not.)",
            buttons, QMessageBox.StandardButton.Save,
        )
        return {QMessageBox.StandardButton.Save: "save", QMessageBox.StandardButton.Discard: "discard"}.get(answer, "cancel")

    def save_session(self, *, wait: bool = False) -> bool:
        """Save to the open session's folder, or ask for one; in the background unless `wait`."""
        folder = self.model.session_path
        if folder is None:
            chosen = QFileDialog.getExistingDirectory(self, "Save the session into a folder")
            if not chosen:
                return False
            folder = Path(chosen)
        return self.files.save(folder, wait=wait)

    def _on_save_session_as(self) -> bool:
        folder = QFileDialog.getExistingDirectory(self, "Save the session into a folder")
        return bool(folder) and self.files.save(Path(folder))

    def _on_saved(self, folder: Path, skipped: list[str]) -> None:
        self._update_title()
        note = f" (left out, their mesh did not load: {', '.join(skipped)})" if skipped else ""
        self.statusBar().showMessage(f"session saved to {folder}{note}")

    def _confirm(self, title: str, text: str) -> bool:
        """Ask yes or no (tests replace this)."""
        answer = QMessageBox.question(self, title, text)
        return answer == QMessageBox.StandardButton.Yes

    def _offer_restore(self, count: int) -> None:
        folder = self.model.autosave_folder()
        if self._confirm("Restore scribbles?", f"{count} shape(s) have autosaved scribbles that differ from the ones "
                         f"opened (the app closed before they were saved).\nRestore them? (No sets the autosave aside in {folder.parent})"):
            restored = self.model.restore_autosave()
            self.statusBar().showMessage(f"restored the scribbles of {len(restored)} shapes (Ctrl+Z undoes each)")
        else:
            self.model.discard_autosave()

    def _on_export_current(self) -> None:
        folder = QFileDialog.getExistingDirectory(self, "Export the current shape to")
        if folder and self.model.current >= 0:
            self.files.export(folder, only=[self.model.current])

    def _on_export(self) -> None:
        folder = QFileDialog.getExistingDirectory(self, "Export labeled meshes to")
        if folder:
            self.files.export(folder)
            self.statusBar().showMessage(f"exporting to {folder}…")

    def _on_error(self, message: str) -> None:
        self.statusBar().showMessage(message)
        box = QMessageBox(QMessageBox.Icon.Warning, "scribbleseg", message, parent=self)
        box.setModal(False)
        box.show()

    # ---------------------------------------------------------------- window

    def showEvent(self, event) -> None:
        super().showEvent(event)
        if not self._placed:
            self._placed = True
            self.place_beside_viewport()

    def place_beside_viewport(self) -> None:
        """Polyscope opens its window near the top-left corner and cannot be moved from
        here: size it to leave room, and put this window to its right."""
        screen = self.screen().availableGeometry() if self.screen() else None
        width = int(min(1280, screen.width() - self.width() - 50)) if screen is not None else 0
        if width < 640:  # too small a screen to share: leave both windows as they are
            return
        height = int(min(screen.height() - 60, width * 0.75))
        self.viewport.set_window_size(width, height)
        self.move(screen.x() + 20 + width + 10, screen.y())

    def closeEvent(self, event) -> None:
        if not self._quitting and not self.keep_unsaved_work():
            event.ignore()
            return
        self.timer.stop()
        self.runs.shutdown()  # waits for the run's thread (it stops at its next step)
        self.previews.close()
        self.view.shutdown()
        self.toolbox.shutdown()
        self.files.shutdown()  # a save or an export under way finishes its files
        super().closeEvent(event)

    def _on_tick(self) -> None:
        if self._viewport is None or not self.frames.due():
            return
        self.frames.rendered(acting=self._viewport.tick(redraw=self.frames.busy))
        if self._viewport.close_requested:  # closing the viewport window quits the app
            self.timer.stop()
            self.keep_unsaved_work(can_cancel=False)  # polyscope cannot take the close back
            self._quitting = True
            self.close()
