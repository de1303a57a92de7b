"""Render PDF pages to PNG for visual checks (pypdfium2, a test dependency: no system
package). ``render(pdf, out_dir)`` writes ``<stem>-NN.png`` per page; ``ink(png)`` is the
fraction of non-white pixels (a blank or clipped page shows up as ~0)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def render(pdf: str | Path, out_dir: str | Path, scale: float = 1.0) -> list[Path]:
    import pypdfium2 as pdfium

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    doc = pdfium.PdfDocument(str(pdf))
    paths = []
    for i in range(len(doc)):
        p = out / f"{Path(pdf).stem}-{i + 1:02d}.png"
        doc[i].render(scale=scale).to_pil().save(p)
        paths.append(p)
    doc.close()
    return paths


def ink(png: str | Path) -> float:
    from PIL import Image

    a = np.asarray(Image.open(png).convert("L"))
    return float(np.mean(a < 200))


def montage(pngs: list[Path], out: str | Path, cols: int = 5) -> Path:
    """All pages side by side in one image (for a reviewer to open once)."""
    from PIL import Image

    ims = [Image.open(p) for p in pngs]
    w, h = ims[0].size
    rows = (len(ims) + cols - 1) // cols
    m = Image.new("RGB", (w * cols, h * rows), "white")
    for k, im in enumerate(ims):
        m.paste(im, ((k % cols) * w, (k // cols) * h))
    m.save(out)
    return Path(out)
