"""Seed 003's task allocation: CarA (the ICF upper tier), its two baselines, the lattice, J*.

Pure and I/O-free (numpy and scipy only): ``graph`` (the lower tier, Sec. 3.5), ``scores``
(Eq. 26 and the parameters), ``agent`` (the per-agent message-based interface the three share),
``icf``, ``gbaa``, ``ica`` (the allocators), ``optimum`` (J* and the optimality gap) and ``sim``
(a discrete-time driver for tests and quick studies). The swarm adapter is
``companion.swarm.caravan``.
"""

from companion.planning.caravan.agent import Allocator, AllocatorStats, make_allocator
from companion.planning.caravan.graph import TaskGraph
from companion.planning.caravan.scores import ALGORITHMS, CaravanParams, bid

__all__ = [
    "ALGORITHMS",
    "Allocator",
    "AllocatorStats",
    "CaravanParams",
    "TaskGraph",
    "bid",
    "make_allocator",
]
