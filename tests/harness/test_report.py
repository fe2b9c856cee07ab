"""Demo metrics are computed from the recorded track, phase boundaries from the client's events."""

import numpy as np
import pytest

from harness.report.demo import demo_metrics, plot_trajectory


def _track():
    t = np.arange(0.0, 40.0, 0.05)
    up = np.clip((t - 5.0) * 1.0, 0.0, 5.0) + 0.2  # climbs 1 m/s from t=5 to 5.2 m
    north = np.clip((t - 15.0) * 4.0, 0.0, 20.0)  # goto from t=15, arrives at t=20
    north[t > 30] = 0.0
    up[t > 35] = 0.2
    landed = np.where((t > 5) & (t < 35), 2.0, 1.0)
    return {
        "time_s": t,
        "east_m": np.zeros_like(t),
        "north_m": north,
        "up_m": up,
        "tilt_deg": np.where(landed == 2.0, 12.0, 0.5),
        "landed_state": landed,
        "armed": (landed == 2.0).astype(float),
        "electrical_power_w": np.where(landed == 2.0, 100.0, 0.0),
        "battery_soc": 1.0 - 0.001 * t,
        "wall_s": 1000.0 + t / 2.0,  # paced at 2x
    }


def _ev(name, sim_t, **kw):
    return {"event": name, "wall_s": 1000.0 + sim_t / 2.0, **kw}


def test_metrics_follow_the_track():
    origin = (47.397742, 8.545594, 488.0)
    import pymap3d

    lat, lon, alt = pymap3d.enu2geodetic(0.0, 20.0, 5.2, *origin)
    events = [
        _ev("takeoff_commanded", 5.0),
        _ev("hover_done", 14.0),
        _ev("goto_commanded", 15.0, lat=lat, lon=lon, alt_amsl_m=alt),
        _ev("goto_settled", 25.0, reported_error_m=0.1),
        _ev("disarmed", 38.0),
    ]
    m = demo_metrics(_track(), events, {"takeoff_alt": 5.0, "hover_s": 5.0}, origin)
    assert m["completed"]
    assert m["climb_time_s"] == pytest.approx(4.75, abs=0.06)  # 95 % of 5 m at 1 m/s
    assert m["hover_error_rms_m"] == pytest.approx(0.0, abs=1e-6)
    assert m["arrival_error_m"] == pytest.approx(0.0, abs=1e-3)
    assert m["max_tilt_deg"] == pytest.approx(12.0)
    assert m["electrical_energy_j"] == pytest.approx(100.0 * 30.0, rel=0.01)
    assert m["hover_power_w"] == pytest.approx(100.0)
    assert m["battery_soc_used"] == pytest.approx(0.001 * 39.95)
    assert "hover_endurance_min" not in m  # no pack given


def test_failed_flight_is_reported_incomplete():
    events = [_ev("takeoff_commanded", 5.0), {"event": "error", "wall_s": 1010.0, "message": "x"}]
    m = demo_metrics(_track(), events, {}, (47.0, 8.0, 400.0))
    assert not m["completed"]
    assert m["error"] == "x"


def test_plot_is_written(tmp_path):
    path = tmp_path / "t.png"
    plot_trajectory(_track(), path, "test")
    assert path.stat().st_size > 10_000


def test_vehicle_time_stamps_win_over_wall_time():
    """An event's vehicle_time_s places it, even when its wall stamp says otherwise."""
    # The wall stamps claim the hover ended at t = 30 s (during the goto and the return); the
    # vehicle's clock says 14 s. The window must come from the vehicle's clock.
    events = [
        _ev("takeoff_commanded", 5.0, vehicle_time_s=5.0),
        {"event": "hover_done", "wall_s": 1015.0, "vehicle_time_s": 14.0},
    ]
    m = demo_metrics(_track(), events, {"takeoff_alt": 5.0, "hover_s": 5.0}, (47.0, 8.0, 400.0))
    assert m["hover_error_rms_m"] == pytest.approx(0.0, abs=1e-6)
    wall_only = [dict(e, vehicle_time_s=None) for e in events]
    m = demo_metrics(_track(), wall_only, {"takeoff_alt": 5.0, "hover_s": 5.0}, (47.0, 8.0, 400.0))
    assert m["hover_error_rms_m"] > 1.0


def test_cruise_speed_is_the_middle_of_the_goto_leg():
    """Median ground speed over 30-70 % of the leg, compared with the vehicle's MPC_XY_CRUISE."""
    origin = (47.397742, 8.545594, 488.0)
    import pymap3d

    lat, lon, alt = pymap3d.enu2geodetic(0.0, 20.0, 5.2, *origin)
    events = [
        _ev("parameters", 0.0, mpc_xy_cruise_m_s=5.0),
        _ev("goto_commanded", 15.0, lat=lat, lon=lon, alt_amsl_m=alt),
        _ev("goto_arrived", 21.0),
        _ev("goto_settled", 25.0, reported_error_m=0.1),
    ]
    m = demo_metrics(_track(), events, {"takeoff_alt": 5.0}, origin)
    assert m["goto_leg_m"] == pytest.approx(20.0, abs=0.1)
    assert m["cruise_speed_m_s"] == pytest.approx(4.0, rel=1e-6)  # the track flies 4 m/s
    assert m["cruise_speed_param_m_s"] == 5.0
    assert m["cruise_speed_error_pct"] == pytest.approx(-20.0, abs=1e-4)
