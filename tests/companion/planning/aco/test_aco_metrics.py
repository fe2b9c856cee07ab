"""Seed 001's metrics, Eqs. 4-10, against Table 2 and hand-computed cases."""

from __future__ import annotations

import pytest

from companion.planning.aco.metrics import (
    average_divergence,
    cost_function,
    flight_time,
    formation_change,
    mission_completion,
    path_quality,
)

# Table 2 (option 2, threshold 0.1 m): obstacles, drones, AD, FT, MC, PQ, FC, CF as printed
TABLE2 = [
    (6, 5, 1, 1.0969, 100, 97.7058, 26.8118, 34.3594),
    (12, 10, 1, 0.6097, 100, 99.7400, 26.0080, 35.0247),
    (25, 20, 1.1, 1.3182, 100, 99.1094, 20.6193, 35.8143),
    (40, 30, 4.33, 0.9135, 100, 94.1925, 20.0458, 34.3799),
    (45, 40, 5.525, 2.0233, 100, 94.5771, 24.6229, 33.0812),
    (60, 50, 8.34, 2.5419, 100, 97.6972, 24.2275, 33.1175),
    (75, 70, 2.3571, 1.5063, 100, 98.8808, 31.3673, 33.3299),
    (85, 80, 4.19, 1.8487, 100, 98.5522, 28.7537, 33.3524),
]


def test_table2_first_row_cf() -> None:
    """Eq. 10 with PQ, MC, FC as percent numbers and FT, AD raw gives row 1's 34.3594."""
    cf = cost_function(pq=97.7058, ft=1.0969, ad=1.0, mc=100.0, fc=26.8118)
    assert cf == pytest.approx(34.3594, abs=1e-4)


@pytest.mark.parametrize("row", TABLE2)
def test_table2_rows_recompute(row: tuple[float, ...]) -> None:
    """Every printed row but N = 60 recomputes to its CF within 1e-3."""
    _, _, ad, ft, mc, pq, fc, cf = row
    assert cost_function(pq, ft, ad, mc, fc) == pytest.approx(cf, abs=1e-3)


def test_table2_sixty_drone_row_is_a_typo() -> None:
    """The N = 60 row's inputs give 35.102, not the printed 35.1919."""
    cf = cost_function(pq=98.9631, ft=1.1032, ad=3.72, mc=100.0, fc=21.63)
    assert cf == pytest.approx(35.102, abs=1e-3)
    assert abs(cf - 35.1919) > 0.05


def test_component_metrics_by_hand() -> None:
    """Eqs. 4-8 on a two-drone case computed by hand; Eq. 9's option-1 weights."""
    assert path_quality([100.0, 90.0], [100.0, 100.0]) == pytest.approx(95.0)
    assert mission_completion([True, False, True, True]) == pytest.approx(75.0)
    assert average_divergence([1, 2, 3]) == pytest.approx(2.0)
    assert flight_time(90.0) == pytest.approx(1.5)
    assert formation_change([0.02, 0.04], 0.1) == pytest.approx(30.0)
    # option 1: 0.3 PQ + 0.3 (1 - FT) + 0.2 (1 - AD) + 0.2 MC
    assert cost_function(95.0, 1.5, 2.0, 75.0) == pytest.approx(28.5 - 0.15 - 0.2 + 15.0)
