"""Clusters of adjacent defective pixels (8-connected) and their size histogram."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

_EIGHT = np.ones((3, 3), dtype=bool)


def find_clusters(defective: np.ndarray, min_size: int) -> dict:
    """Label 8-connected groups of ``defective`` pixels.

    Returns ``size_histogram`` {size: number of groups} over all groups (singletons
    included), and ``clusters``: a list of groups with >= ``min_size`` pixels, each with
    its size and bounding box (local row/col, inclusive), largest first.
    """
    labels, n = ndimage.label(defective, structure=_EIGHT)
    if n == 0:
        return {"size_histogram": {}, "clusters": [], "labels": labels}
    sizes = np.bincount(labels.ravel(), minlength=n + 1)[1:]
    hist_sizes, hist_counts = np.unique(sizes, return_counts=True)
    big = np.flatnonzero(sizes >= min_size)
    clusters = []
    if big.size:
        # bounding boxes from the (few) defective pixels only, not a scan of the image
        rr, cc = np.nonzero(labels)
        lab = labels[rr, cc] - 1
        keep = np.isin(lab, big)
        rr, cc, lab = rr[keep], cc[keep], lab[keep]
        r0 = np.full(n, np.iinfo(np.int64).max); r1 = np.full(n, -1)  # noqa: E702
        c0 = np.full(n, np.iinfo(np.int64).max); c1 = np.full(n, -1)  # noqa: E702
        np.minimum.at(r0, lab, rr); np.maximum.at(r1, lab, rr)  # noqa: E702
        np.minimum.at(c0, lab, cc); np.maximum.at(c1, lab, cc)  # noqa: E702
        for i in big[np.argsort(-sizes[big], kind="stable")]:
            clusters.append({"label": int(i + 1), "size": int(sizes[i]),
                             "row0": int(r0[i]), "row1": int(r1[i]), "col0": int(c0[i]), "col1": int(c1[i])})
    return {"size_histogram": {int(s): int(c) for s, c in zip(hist_sizes, hist_counts)},
            "clusters": clusters, "labels": labels}
