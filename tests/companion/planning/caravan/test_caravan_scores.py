"""Seed 003's bid (Eq. 26) and the parameters' validation."""

from __future__ import annotations

import numpy as np
import pytest

from companion.planning.caravan.scores import CaravanParams, bid


def test_bid_decays_with_time_unlike_eq28_as_printed() -> None:
    """Eq. (26) falls with t (a at 0, a/e at 1/lambda); Eq. (28)'s a lambda^-t would rise."""
    t = np.array([0.0, 5.0, 10.0])
    s = bid(1000.0, 0.1, t)
    np.testing.assert_allclose(s, [1000.0, 1000.0 * np.exp(-0.5), 1000.0 / np.e])
    assert np.all(np.diff(s) < 0) and np.all(np.diff(1000.0 * 0.1 ** (-t)) > 0)


def test_bids_count_the_visit_time_from_the_mission_start() -> None:
    """A bid at time now for travel t equals the score at now + t (a straight flyer keeps it)."""
    p = CaravanParams()
    np.testing.assert_allclose(p.bids(2.0, np.array([3.0])), p.bids(4.0, np.array([1.0])))


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("algorithm", "cbba"),
        ("reward", 0.0),
        ("discount_per_s", 1.5),
        ("epsilon", -1e-6),
        ("speed_m_s", 0.0),
        ("release_timeout_s", float("nan")),
        ("arrive_tolerance_m", -0.1),
        ("altitude_m", 0.0),
        ("altitude_step_m", "high"),
        ("decision_period_s", 0.0),
    ],
)
def test_bad_parameters_raise_naming_the_field(field: str, value: object) -> None:
    """Every bad value is a ValueError whose message starts with the field's name."""
    with pytest.raises(ValueError, match=f"^{field}:"):
        CaravanParams(**{field: value})  # type: ignore[arg-type]
