"""Seed 004's clustering baseline: K-means of the free waypoints with k = n (Sec. 4.2.2 and 5)."""

from __future__ import annotations

import numpy as np
from scipy.cluster.vq import ClusterError, kmeans2

from companion.planning.mco.partition import Partition, check_n
from companion.planning.mco.workspace import Grid, default_takeoff_xy_m

_ITER = 100
"""Lloyd iterations per run (scipy's default of 10 stops short of convergence on ~2000 points)."""
_TRIES = 10
"""k-means++ restarts before an empty cluster is repaired by hand."""


def kmeans_partition(
    grid: Grid,
    n: int,
    rng: np.random.Generator,
    takeoff_xy_m: np.ndarray | None = None,
) -> Partition:
    """Seed 004's K-means baseline: ``n`` non-empty clusters of the waypoints; sites = centroids.

    scipy's ``kmeans2`` (k-means++ start, seeded by ``rng``) is restarted when a cluster comes out
    empty; after _TRIES restarts each empty cluster takes the waypoint farthest from the centroid
    of the largest cluster (our choice), and the centroids are recomputed. ``takeoff_xy_m``
    (default: the free waypoint nearest the waypoints' mean) is only recorded.
    """
    xy = grid.waypoints_xy_m
    check_n(n, len(xy))
    labels = None
    for _ in range(_TRIES):
        try:
            _, labels = kmeans2(xy, n, iter=_ITER, minit="++", seed=rng, missing="raise")
            break
        except ClusterError:
            labels = None
    if labels is None:
        _, labels = kmeans2(xy, n, iter=_ITER, minit="++", seed=rng, missing="warn")
        labels = _fill_empty(xy, labels.astype(np.int64), n)
    labels = labels.astype(np.int64)
    sites = np.array([xy[labels == i].mean(axis=0) for i in range(n)])
    p0 = default_takeoff_xy_m(grid) if takeoff_xy_m is None else np.asarray(takeoff_xy_m, float)
    return Partition(labels, sites, p0.reshape(1, 2), "kmeans")


def _fill_empty(xy: np.ndarray, labels: np.ndarray, n: int) -> np.ndarray:
    """Give every empty cluster the farthest waypoint of the currently largest cluster."""
    labels = labels.copy()
    for empty in np.flatnonzero(np.bincount(labels, minlength=n) == 0):
        largest = int(np.argmax(np.bincount(labels, minlength=n)))
        members = np.flatnonzero(labels == largest)
        gap = np.sum((xy[members] - xy[members].mean(axis=0)) ** 2, axis=1)
        labels[members[int(np.argmax(gap))]] = empty
    return labels
