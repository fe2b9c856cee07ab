"""A* on seed 001's roadmap: the shortest-path baseline the paper lacks (digest 004_001 §3).

Same roadmap and output as :func:`companion.planning.aco.colony.aco_path`: the start -> target
node sequence and its length. Edge cost is the Euclidean edge length, the heuristic the straight
distance to the target (admissible and consistent, so the first time the target is popped its
path is a shortest one). A binary heap (``heapq``) over the CSR arrays; ties are broken by node
index, so the result is deterministic.
"""

from __future__ import annotations

import heapq

import numpy as np

from companion.planning.aco.roadmap import START, TARGET, Roadmap


def astar_path(roadmap: Roadmap) -> tuple[np.ndarray, float]:
    """The shortest start -> target node sequence on ``roadmap`` and its length, m.

    Raises ``ValueError`` if the target cannot be reached (a roadmap from
    :func:`~companion.planning.aco.roadmap.build_roadmap` never has that).
    """
    pts = roadmap.points_enu_m
    h = np.linalg.norm(pts - pts[TARGET], axis=1).tolist()
    indptr = roadmap.indptr.tolist()
    indices = roadmap.indices.tolist()
    length = roadmap.length_m.tolist()
    n = roadmap.n_nodes
    g = [float("inf")] * n
    parent = [-1] * n
    closed = [False] * n
    g[START] = 0.0
    heap = [(h[START], START)]
    while heap:
        _, i = heapq.heappop(heap)
        if closed[i]:
            continue
        if i == TARGET:
            break
        closed[i] = True
        gi = g[i]
        for s in range(indptr[i], indptr[i + 1]):
            j = indices[s]
            cost = gi + length[s]
            if cost < g[j]:
                g[j] = cost
                parent[j] = i
                heapq.heappush(heap, (cost + h[j], j))
    if g[TARGET] == float("inf"):
        raise ValueError(
            f"target {tuple(pts[TARGET].tolist())} is unreachable from start "
            f"{tuple(pts[START].tolist())} on the roadmap"
        )
    path = [TARGET]
    while path[-1] != START:
        path.append(parent[path[-1]])
    return np.array(path[::-1], dtype=np.int64), g[TARGET]
