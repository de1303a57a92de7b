"""Image view: live preview / signal map / noise map with region outlines.

With ``on_edit`` (the live image), regions whose Draw box is ticked get move/resize
handles (a pyqtgraph RectROI snapped to whole pixels); a finished drag calls
``on_edit(row, x, y, width, height)``, which writes the RoA table's model. With
``on_new``, the "New Region" button arms the image: the next left-button drag draws a
rectangle (snapped to pixels, clipped to the image) and ``on_new(x, y, width, height)``
adds it to the table."""

from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QRectF, Qt, QTimer
from PySide6.QtWidgets import QGraphicsRectItem, QHBoxLayout, QLabel, QPushButton, QVBoxLayout, QWidget

from ares.gui.models.image import ImageModel
from ares.gui.plots import plain_axes, region_color, set_colorbar_levels


class ImagePlot(QWidget):
    def __init__(self, model: ImageModel, parent: QWidget | None = None, colorbar: bool = True,
                 cmap: str = "viridis", on_edit=None, on_new=None, overlay=None) -> None:
        super().__init__(parent)
        self.model = model
        self.on_edit = on_edit
        self.on_new = on_new
        self.rois: dict[int, pg.RectROI] = {}
        self._drawn_rects = None
        self.caption = QLabel(model.title)
        self.plot = pg.PlotWidget()
        self.plot.setAspectLocked(True)
        self.plot.invertY(True)
        self.plot.setLabel("bottom", "column")
        self.plot.setLabel("left", "row")
        plain_axes(self.plot)  # no "(x0.001)" on an empty image's axes
        self.image_item = pg.ImageItem()
        self.plot.addItem(self.image_item)
        self.colorbar = None
        if colorbar:
            self.colorbar = pg.ColorBarItem(colorMap=pg.colormap.get(cmap), interactive=False, width=12)
            self.colorbar.setImageItem(self.image_item, insert_in=self.plot.getPlotItem())
        self._rects: list = []
        lay = QVBoxLayout(self)
        lay.setContentsMargins(2, 2, 2, 2)
        top = QHBoxLayout()
        top.addWidget(self.caption, 1)
        self.new_button = None
        self._rubber = None
        if on_new is not None:
            self.new_button = QPushButton("New Region")
            self.new_button.setCheckable(True)
            self.new_button.setToolTip("Then drag on the image: the rectangle becomes a region of analysis.")
            top.addWidget(self.new_button)
            vb = self.plot.getViewBox()
            default_drag = vb.mouseDragEvent

            def drag(ev, axis=None):
                if self.new_button.isChecked() and ev.button() == Qt.MouseButton.LeftButton:
                    ev.accept()
                    self.drag_to(vb.mapSceneToView(ev.buttonDownScenePos()), vb.mapSceneToView(ev.scenePos()),
                                 ev.isFinish())
                else:
                    default_drag(ev, axis)

            vb.mouseDragEvent = drag
        lay.addLayout(top)
        lay.addWidget(self.plot, 1)
        self._shape = None
        self._levels = None
        self.overlay_items: list = []
        self.overlay = overlay  # a DefectCountsModel: its map drawn over the image when switched on
        if overlay is not None:
            overlay.subscribe(lambda _: self._draw_overlay())
        model.subscribe(lambda _: self.refresh())
        self.refresh()

    def refresh(self) -> None:
        m = self.model
        if m.rectangles != self._drawn_rects:
            self._draw_rectangles()
        self.caption.setText(f"{m.title}" + (f" — {m.caption}" if m.caption else ""))
        if m.image is not None:
            image = m.image if m.image.dtype.kind in "ui" else np.asarray(m.image, dtype=np.float32)
            self.image_item.setImage(image, autoLevels=False, levels=m.levels)  # frames as they come: no copy
            if self.colorbar is not None and m.levels != self._levels:  # its axis redrawn only on a change
                self._levels = m.levels
                set_colorbar_levels(self.colorbar, m.levels)
            if m.image.shape != self._shape:
                self._shape = m.image.shape
                self.plot.getPlotItem().autoRange()
        elif self.image_item.image is not None:  # a new run: nothing of the previous one stays drawn
            self.image_item.clear()
            self._shape = None

    def _draw_rectangles(self) -> None:
        for item in self._rects:
            self.plot.removeItem(item)
        self._rects = []
        self.rois = {}
        self._drawn_rects = list(self.model.rectangles)
        for i, r in self.model.rectangles:
            color = region_color(i)
            if self.on_edit is not None and r.draw:
                roi = pg.RectROI([r.x, r.y], [r.width, r.height], pen=pg.mkPen(color, width=2),
                                 snapSize=1, translateSnap=True, scaleSnap=True, removable=False)
                roi.sigRegionChangeFinished.connect(lambda roi_, row=i: self._roi_moved(row, roi_))
                label = pg.TextItem(str(i + 1), color=color, fill=(255, 255, 255, 200), anchor=(0, 1))
                label.setPos(r.x, r.y)
                for item in (roi, label):
                    self.plot.addItem(item)
                    self._rects.append(item)
                self.rois[i] = roi
                continue
            items = []
            for pen_color, width in (((255, 255, 255), 4), (color, 2)):  # a light halo, then the colour
                rect = QGraphicsRectItem(QRectF(r.x, r.y, r.width, r.height))
                pen = pg.mkPen(pen_color, width=width)
                pen.setCosmetic(True)
                rect.setPen(pen)
                items.append(rect)
            label = pg.TextItem(str(i + 1), color=color, fill=(255, 255, 255, 200), anchor=(0, 1))
            label.setPos(r.x, r.y)
            for item in (*items, label):
                self.plot.addItem(item)
                self._rects.append(item)

    def _roi_moved(self, row: int, roi) -> None:
        x, y = (int(round(v)) for v in roi.pos())
        w, h = (max(1, int(round(v))) for v in roi.size())
        # later, not inside the ROI's own signal: the edit redraws (and so deletes) this ROI
        QTimer.singleShot(0, lambda: self.on_edit(row, x, y, w, h))

    def _draw_overlay(self) -> None:
        from ares.gui.models.defects import DEFECT_COLORS

        for item in self.overlay_items:
            self.plot.removeItem(item)
        self.overlay_items = []
        m = self.overlay
        for cls, pts in m.points().items():
            color = DEFECT_COLORS.get(cls, (90, 90, 90))
            item = pg.ScatterPlotItem(pts[:, 0] + 0.5, pts[:, 1] + 0.5, size=9, symbol="s", brush=None,
                                      pen=pg.mkPen(color, width=1.5), name=cls)
            self.plot.addItem(item)
            self.overlay_items.append(item)
        if m.overlay and m.map:
            pen = pg.mkPen((220, 30, 30), width=1, style=Qt.PenStyle.DashLine)
            for x in m.map.get("bad_column_x") or []:
                line = pg.InfiniteLine(x + 0.5, angle=90, pen=pen)
                self.plot.addItem(line)
                self.overlay_items.append(line)
            for y in m.map.get("bad_row_y") or []:
                line = pg.InfiniteLine(y + 0.5, angle=0, pen=pen)
                self.plot.addItem(line)
                self.overlay_items.append(line)

    def drag_to(self, start, end, finish: bool) -> None:
        """A New Region drag from ``start`` to ``end`` (image coordinates): a rubber band
        while dragging; on release the pixel rectangle goes to ``on_new``."""
        rows, cols = self._shape or (0, 0)
        x0, x1 = sorted((start.x(), end.x()))
        y0, y1 = sorted((start.y(), end.y()))
        x0, y0 = max(0, int(round(x0))), max(0, int(round(y0)))
        x1, y1 = min(cols, int(round(x1))), min(rows, int(round(y1)))
        if self._rubber is None:
            self._rubber = QGraphicsRectItem()
            pen = pg.mkPen((255, 200, 0), width=2, style=Qt.PenStyle.DashLine)
            pen.setCosmetic(True)
            self._rubber.setPen(pen)
            self.plot.addItem(self._rubber)
        self._rubber.setRect(QRectF(x0, y0, max(x1 - x0, 0), max(y1 - y0, 0)))
        if finish:
            self.plot.removeItem(self._rubber)
            self._rubber = None
            self.new_button.setChecked(False)
            if x1 > x0 and y1 > y0:
                QTimer.singleShot(0, lambda: self.on_new(x0, y0, x1 - x0, y1 - y0))

    @property
    def rectangle_count(self) -> int:
        return sum(isinstance(i, QGraphicsRectItem) for i in self._rects) // 2 + len(self.rois)
