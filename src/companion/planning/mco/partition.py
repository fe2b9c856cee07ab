"""Seed 004's area partitioning: the MCO extended Voronoi tessellation (Sec. 4.2.2, Phases I-IV).

The Voronoi tessellation is discrete: a free waypoint belongs to its nearest site. Phase I puts
p0 and sites on a circle around it (Postulate 1: 2-4 divisions); Phases II-III grow the largest
sub-area by moving its site a third of the radius closer, then split it with a new circle of
sites (Postulate 2: 2-4 sub-areas), until the level holds its share of n (Postulate 3: <= 16);
Phase IV makes v = floor(n / 16) + 1 levels, each around its own take-off p0. A final repair
makes every sub-area connected in the grid's 8-neighbourhood.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.cluster.vq import kmeans2
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from companion.planning.mco.workspace import Grid, Workspace, default_takeoff_xy_m

LEVEL_MAX = 16
"""Postulate 3, seed 004: a Partition Level has at most 16 sub-areas."""
BASE_MAX = 4
"""Postulates 1 and 2, seed 004: a Base Partition or a Sub-partition has 2-4 divisions."""
_CIRCLE_TRIES = 20
"""Random circles drawn before falling back to sites on waypoints (non-empty by construction)."""


@dataclass(frozen=True)
class Partition:
    """Sub-areas of a grid's waypoints, one per MAV (P5: disjoint)."""

    labels: np.ndarray
    """(K,) sub-area of each grid waypoint, 0..n-1; every sub-area non-empty."""
    sites_xy_m: np.ndarray
    """(n, 2) a representative point per sub-area (Voronoi site for MCO, centroid otherwise), m."""
    takeoff_xy_m: np.ndarray
    """(v, 2) take-off locations p0 (MCO Phase IV gives several; baselines the one p0), m."""
    method: str
    """Which partitioner made it: "mco", "boustrophedon" or "kmeans"."""

    @property
    def n(self) -> int:
        """Number of sub-areas."""
        return int(self.sites_xy_m.shape[0])

    def counts(self) -> np.ndarray:
        """Waypoints per sub-area, (n,)."""
        return np.bincount(self.labels, minlength=self.n)


def heterogeneity_std_pct(partition: Partition) -> float:
    """Heterogeneity magnitude of Fig. 15, seed 004, in %.

    Population standard deviation (ddof = 0) of the waypoint counts over the n sub-areas, divided
    by the total number of waypoints, times 100. The paper reports a std in % without stating the
    normalisation; this one is our choice (the digest's most likely reading).
    """
    counts = partition.counts()
    return float(np.std(counts) / counts.sum() * 100.0)


def check_n(n: int, waypoints: int) -> None:
    """ValueError naming n unless 2 <= n <= the number of waypoints."""
    if not 2 <= n <= waypoints:
        raise ValueError(f"n={n} sub-areas: n must be in [2, {waypoints}] (the grid's waypoints)")


def mco_partition(
    grid: Grid,
    workspace: Workspace,
    n: int,
    rng: np.random.Generator,
    takeoff_xy_m: np.ndarray | None = None,
) -> Partition:
    """Seed 004's MCO partition of ``grid`` into exactly ``n`` connected sub-areas (Sec. 4.2.2).

    ``takeoff_xy_m``: p0, shape (2,) for n <= 16, or (v, 2) with v = floor(n / 16) + 1 for
    n > 16; default: the free waypoint nearest the waypoints' mean (one level), or the waypoints
    nearest v k-means centres of the waypoints (Phase IV).
    """
    xy = grid.waypoints_xy_m
    check_n(n, len(xy))
    v = 1 if n <= LEVEL_MAX else n // LEVEL_MAX + 1  # Phase IV: v = floor(n / 16) + 1
    takeoffs = _takeoffs(grid, v, rng, takeoff_xy_m)
    if v == 1:
        domains = [np.arange(len(xy))]
        widths = [workspace.width_m]  # Phase I: r = (bounding-box E-W extent) / n
    else:
        # Phase IV: a level's domain is the discrete Voronoi cell of its p0 among all p0.
        nearest = cKDTree(takeoffs).query(xy)[1]
        domains = [np.flatnonzero(nearest == level) for level in range(v)]
        widths = [float(np.ptp(xy[d, 0])) + grid.cell_m[0] for d in domains]
    shares = _level_shares(n, [len(d) for d in domains])
    labels = np.empty(len(xy), dtype=np.int64)
    sites: list[np.ndarray] = []
    for domain, p0, width, share in zip(domains, takeoffs, widths, shares, strict=True):
        local, level_sites = _level(xy[domain], p0, width, share, rng)
        labels[domain] = local + len(sites)
        sites.extend(level_sites)
    labels = repair_connectivity(grid, labels, n)
    return Partition(labels, np.asarray(sites), np.atleast_2d(takeoffs), "mco")


def _takeoffs(
    grid: Grid, v: int, rng: np.random.Generator, takeoff_xy_m: np.ndarray | None
) -> np.ndarray:
    """The v take-off locations p0, (v, 2)."""
    if takeoff_xy_m is not None:
        given = np.asarray(takeoff_xy_m, dtype=float).reshape(-1, 2)
        if given.shape[0] != v:
            raise ValueError(
                f"takeoff_xy_m has {given.shape[0]} locations; this n needs v={v} (Phase IV)"
            )
        return given
    if v == 1:
        return default_takeoff_xy_m(grid)[None, :]
    # Phase IV placement (not given by the paper; our choice): k-means centres of the waypoints,
    # each snapped to its nearest free waypoint.
    xy = grid.waypoints_xy_m
    centres, _ = kmeans2(xy, v, minit="++", seed=rng)
    return xy[cKDTree(xy).query(centres)[1]]


def _level_shares(n: int, domain_sizes: list[int]) -> list[int]:
    """Sub-areas per level: n split as evenly as possible, the larger shares to larger domains."""
    v = len(domain_sizes)
    even = [n // v + (1 if i < n % v else 0) for i in range(v)]  # our choice: even, not 16 + rest
    shares = [0] * v
    for rank, level in enumerate(np.argsort(domain_sizes, kind="stable")[::-1]):
        shares[level] = even[rank]
        if even[rank] > domain_sizes[level]:
            raise ValueError(
                f"n={n}: level {level} has {domain_sizes[level]} waypoints for {even[rank]} "
                "sub-areas"
            )
    return shares


def _nearest(xy: np.ndarray, sites: np.ndarray) -> np.ndarray:
    """Discrete Voronoi: index of the nearest site of each point."""
    return cKDTree(sites).query(xy)[1].astype(np.int64)


def _circle(
    xy: np.ndarray, centre: np.ndarray, radius_m: float, k: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Phase I, seed 004: ``centre`` and k - 1 sites at random angles on a circle around it.

    Our choice: the sites lie *on* the circle (the text says both "follow a circumference" and
    "inside"). Returns (labels of ``xy``, (k, 2) sites); every site gets a point. A draw leaving
    a site without a point is redrawn; after _CIRCLE_TRIES draws the sites become k distinct
    random points of ``xy`` (``centre`` first), which are non-empty by construction.
    """
    for _ in range(_CIRCLE_TRIES):
        angles = rng.uniform(0.0, 2.0 * np.pi, k - 1)
        ring = centre + radius_m * np.column_stack([np.cos(angles), np.sin(angles)])
        sites = np.vstack([centre, ring])
        labels = _nearest(xy, sites)
        if np.bincount(labels, minlength=k).min() > 0:
            return labels, sites
    c = int(np.argmin(np.sum((xy - centre) ** 2, axis=1)))
    others = rng.choice(np.delete(np.arange(len(xy)), c), size=k - 1, replace=False)
    sites = xy[np.concatenate([[c], others])]
    return _nearest(xy, sites), sites


def _level(
    xy: np.ndarray, p0: np.ndarray, width_m: float, m: int, rng: np.random.Generator
) -> tuple[np.ndarray, list[np.ndarray]]:
    """One Partition Level of m sub-areas around p0 (Phases I-III); local labels and sites."""
    radius = width_m / m  # Phase I: r = measured width / n (n = this level's share)
    base = min(m, BASE_MAX)  # Postulate 1
    labels, first = _circle(xy, p0, radius, base, rng)
    sites = list(first)
    group = [0] * base  # sites that were placed together (siblings) share a group
    group_radius = [radius]
    while len(sites) < m:
        counts = np.bincount(labels, minlength=len(sites))
        chosen = int(np.argmax(counts))  # the largest sub-area (lowest index on a tie)
        siblings = [i for i in range(len(sites)) if group[i] == group[chosen]]
        # Phase II (base level): move its site r/3 toward p0; Phase III (and p0's own cell): toward
        # the nearest sibling site ("the closer p centroid"). Our choice: only the siblings'
        # waypoints are re-tessellated, so earlier splits stay nested.
        if group[chosen] == 0 and not np.allclose(sites[chosen], p0):
            target = p0
        else:
            others = [i for i in siblings if i != chosen]
            target = sites[
                min(others, key=lambda i: float(np.sum((sites[i] - sites[chosen]) ** 2)))
            ]
        step = target - sites[chosen]
        dist = float(np.hypot(*step))
        if dist > 0.0:
            moved = sites[chosen] + step * min(1.0, group_radius[group[chosen]] / 3.0 / dist)
            members = np.flatnonzero(np.isin(labels, siblings))
            trial = np.array([moved if i == chosen else sites[i] for i in siblings])
            relabel = np.asarray(siblings)[_nearest(xy[members], trial)]
            # Our choice: a move that would empty a sibling is not made.
            if np.all(np.isin(siblings, relabel)):
                sites[chosen] = moved
                labels[members] = relabel
        # Split the moved (now larger) sub-area with a new circle at its centre. Postulate 2 vs
        # the (n - 3) rule: k = min(4, sub-areas still missing + 1), which is n - 3 for n = 5..7.
        region = np.flatnonzero(labels == chosen)
        k = min(BASE_MAX, m - len(sites) + 1, len(region))
        pts = xy[region]
        centre = pts[int(np.argmin(np.sum((pts - pts.mean(axis=0)) ** 2, axis=1)))]
        sub_radius = (float(np.ptp(pts[:, 0])) + 1e-9) / k  # Phase I rule on the sub-area
        sub_labels, sub_sites = _circle(pts, centre, sub_radius, k, rng)
        new_group = len(group_radius)
        group_radius.append(sub_radius)
        new_index = [chosen, *range(len(sites), len(sites) + k - 1)]
        sites[chosen] = sub_sites[0]
        group[chosen] = new_group
        sites.extend(sub_sites[1:])
        group.extend([new_group] * (k - 1))
        labels[region] = np.asarray(new_index)[sub_labels]
    return labels, sites


def grid_edges(grid: Grid) -> np.ndarray:
    """(E, 2) index pairs of waypoints that are 8-neighbours on the lattice (each pair once)."""
    width = int(grid.col.max()) + 3
    key = (grid.row + 1) * width + (grid.col + 1)
    order = np.argsort(key)
    sorted_key = key[order]
    pairs = []
    for dr, dc in ((0, 1), (1, -1), (1, 0), (1, 1)):
        target = key + dr * width + dc
        pos = np.searchsorted(sorted_key, target)
        pos = np.minimum(pos, len(sorted_key) - 1)
        hit = sorted_key[pos] == target
        pairs.append(np.column_stack([np.flatnonzero(hit), order[pos[hit]]]))
    return np.vstack(pairs)


def repair_connectivity(grid: Grid, labels: np.ndarray, n: int) -> np.ndarray:
    """Make every sub-area 8-connected: each fragment joins the neighbour it touches most.

    A sub-area keeps its largest 8-connected component; every other fragment is moved to the
    sub-area whose largest component it shares most lattice edges with (a Voronoi cell can be cut
    in two by a hole or a ZLI). A fragment touching no other sub-area's main component stays
    (only possible where the free grid itself is disconnected).
    """
    labels = labels.copy()
    edges = grid_edges(grid)
    k = len(labels)
    for _ in range(k):
        same = labels[edges[:, 0]] == labels[edges[:, 1]]
        e = edges[same]
        graph = sparse.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(k, k))
        n_comp, comp = connected_components(graph, directed=False)
        size = np.bincount(comp, minlength=n_comp)
        main = np.full(n, -1)
        for c in np.argsort(-size, kind="stable"):
            lab = labels[np.flatnonzero(comp == c)[0]]
            if main[lab] < 0:
                main[lab] = c
        is_main = np.zeros(n_comp, dtype=bool)
        is_main[main[main >= 0]] = True
        if is_main.sum() == n_comp:
            return labels
        cross = edges[~same]
        a, b = comp[cross[:, 0]], comp[cross[:, 1]]
        both = np.concatenate([np.column_stack([a, b]), np.column_stack([b, a])])
        # fragment -> main component of another sub-area
        useful = both[~is_main[both[:, 0]] & is_main[both[:, 1]]]
        if len(useful) == 0:
            return labels
        moved = False
        for frag in np.unique(useful[:, 0]):
            contacts = np.bincount(useful[useful[:, 0] == frag, 1], minlength=n_comp)
            dest = int(np.argmax(contacts))
            labels[comp == frag] = labels[np.flatnonzero(comp == dest)[0]]
            moved = True
        if not moved:
            return labels
    return labels
