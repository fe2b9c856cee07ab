"""Offboard control flown on the full stack in lockstep, setpoints sent as MAVSDK sends them.

A raw pymavlink client streams SET_POSITION_TARGET_LOCAL_NED / _GLOBAL_INT and
SET_ATTITUDE_TARGET over real UDP to one vehicle of an in-process Simulation, with the
type_masks and frames of MAVSDK's offboard plugin (MAVSDK_CONTRACT.md section 8). Streams and
waits are in simulated time (the client steps the simulation), so the outcome does not depend
on the machine's load. Positions checked are the autopilot's own estimate.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable

import numpy as np
import pytest
from mission_link import SimLink, offset_deg
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu import quaternion as quat
from autopilot_emu.modes import AutoSubMode, LandedState, MainMode

pytestmark = pytest.mark.sockets

OFFBOARD, AUTO = int(MainMode.OFFBOARD), int(MainMode.AUTO)
ACCEPTED, DENIED = 0, 2
POSITION_NED, VELOCITY_NED, VELOCITY_BODY = 0x09F8, 0x09C7, 0x05C7
ACCELERATION_XY_HOLD_Z = 0x0C3B  # x, y acceleration; z position; no yaw or yaw rate
ATTITUDE, ATTITUDE_RATE = 0x07, 0x80
STREAM_HZ = 20.0
"""MAVSDK's offboard sender rate (SEND_INTERVAL_S = 0.05), here in simulated time."""


def local_ned(mask: int, frame: int = mavlink2.MAV_FRAME_LOCAL_NED, **values: float):
    fields = dict.fromkeys(("x", "y", "z", "vx", "vy", "vz", "afx", "afy", "afz"), 0.0)
    fields.update(yaw=0.0, yaw_rate=0.0)
    fields.update(values)
    return mavlink2.MAVLink_set_position_target_local_ned_message(
        0, 1, 1, frame, mask, *fields.values()
    )


def attitude_target(
    roll_deg: float, pitch_deg: float, yaw_deg: float, thrust: float, mask: int = ATTITUDE
):
    q = quat.from_euler(np.radians([[roll_deg, pitch_deg, yaw_deg]]))[0]
    return mavlink2.MAVLink_set_attitude_target_message(0, 1, 1, mask, q.tolist(), 0, 0, 0, thrust)


class OffboardLink(SimLink):
    """SimLink plus a setpoint stream paced in simulated time."""

    def stream(self, make: Callable[[], mavlink2.MAVLink_message], seconds: float) -> None:
        """Send ``make()`` every 1/STREAM_HZ simulated seconds for ``seconds``."""
        end = self.sim.time_s + seconds
        while self.sim.time_s < end - 1e-9:
            self.send(make())
            self.run(1.0 / STREAM_HZ)

    def start(self, make: Callable[[], mavlink2.MAVLink_message]) -> int:
        """As MAVSDK's offboard.start(): a setpoint first, then DO_SET_MODE OFFBOARD."""
        self.send(make())
        self.run(0.02)
        return self.set_mode(OFFBOARD)

    def ned(self) -> np.ndarray:
        return np.array(self.truth_ned())

    def yaw_deg(self) -> float:
        return math.degrees(float(quat.yaw_of(self.sim.fleet.estimator.r)[0]))

    def velocity(self) -> np.ndarray:
        return self.sim.fleet.estimator.velocity_ned_m_s[0].copy()


@pytest.fixture
def link():
    lk = OffboardLink.open(seed=5)
    lk.wait_ready()
    yield lk
    lk.close()


@pytest.fixture
def flying(link):
    """Armed and hovering 5 m up in Offboard, started from the ground as MAVSDK's examples do."""
    assert link.arm() == ACCEPTED
    start = link.ned()
    hover = local_ned(POSITION_NED, x=start[0], y=start[1], z=start[2] - 5.0)
    assert link.start(lambda: hover) == ACCEPTED
    link.stream(lambda: hover, 10.0)
    assert link.commander.landed_state == LandedState.IN_AIR
    return link


def test_offboard_is_denied_without_a_fresh_setpoint_stream(link):
    assert link.arm() == ACCEPTED
    assert link.set_mode(OFFBOARD) == DENIED
    link.send(local_ned(POSITION_NED))
    link.run(1.5)  # COM_OF_LOSS_T is 1 s: that setpoint is stale now
    assert link.set_mode(OFFBOARD) == DENIED
    assert any("Offboard denied" in t for t in link.texts)
    assert link.commander.main_mode == MainMode.AUTO


def test_position_ned_takes_off_flies_and_turns(flying):
    lk = flying
    start = lk.ned()
    hb = lk.wait_type("HEARTBEAT")
    assert (hb.custom_mode >> 16) & 0xFF == OFFBOARD
    target = start + np.array([8.0, -4.0, -2.0])
    sp = local_ned(POSITION_NED, x=target[0], y=target[1], z=target[2], yaw=math.radians(90))
    lk.stream(lambda: sp, 15.0)
    assert np.linalg.norm(lk.ned() - target) < 0.5
    assert lk.yaw_deg() == pytest.approx(90.0, abs=5.0)


def test_setpoints_are_streamed_back_as_position_and_attitude_targets(flying):
    """POSITION_TARGET_LOCAL_NED carries the offboard target, ATTITUDE_TARGET the attitude and
    thrust being flown (PX4's onboard profile: 10 Hz each)."""
    lk = flying
    target = lk.ned() + np.array([3.0, 2.0, -1.0])
    sp = local_ned(POSITION_NED, x=target[0], y=target[1], z=target[2], yaw=math.radians(45))
    lk.stream(lambda: sp, 1.0)
    echo = lk.wait_type("POSITION_TARGET_LOCAL_NED")
    assert [echo.x, echo.y, echo.z] == pytest.approx(target.tolist(), abs=1e-3)
    assert echo.yaw == pytest.approx(math.radians(45), abs=1e-4)
    assert echo.type_mask & mavlink2.POSITION_TARGET_TYPEMASK_AX_IGNORE
    hover = float(lk.sim.fleet.hover_thrust[0])  # the learned hover thrust in use
    tilt = attitude_target(5.0, 0.0, 45.0, hover)
    lk.stream(lambda: tilt, 0.5)
    lk.inbox.clear()
    echo = lk.wait_type("ATTITUDE_TARGET")
    q = quat.from_euler(np.radians([[5.0, 0.0, 45.0]]))[0]
    assert abs(float(np.dot(echo.q, q))) == pytest.approx(1.0, abs=1e-4)
    assert echo.thrust == pytest.approx(hover, abs=1e-4)


def test_velocity_ned_and_body_velocity_with_yaw_rate(flying):
    lk = flying
    east = local_ned(VELOCITY_NED, vy=2.0, yaw=math.radians(90))
    lk.stream(lambda: east, 6.0)
    # The velocity integrator needs a while to cancel the drag, so the speed may still be
    # approaching 2 m/s here.
    assert lk.velocity() == pytest.approx([0.0, 1.8, 0.0], abs=0.3)
    assert lk.yaw_deg() == pytest.approx(90.0, abs=5.0)
    # Body frame, heading east: forward is east, right is south.
    right = local_ned(VELOCITY_BODY, mavlink2.MAV_FRAME_BODY_NED, vy=1.5)
    lk.stream(lambda: right, 6.0)
    assert lk.velocity() == pytest.approx([-1.4, 0.0, 0.0], abs=0.3)
    # A yaw rate turns the vehicle, and the body velocity turns with it: a circle.
    start_yaw = lk.yaw_deg()
    turn = local_ned(VELOCITY_BODY, mavlink2.MAV_FRAME_BODY_NED, vx=2.0, yaw_rate=math.radians(30))
    lk.stream(lambda: turn, 3.0)
    turned = (lk.yaw_deg() - start_yaw) % 360.0
    assert turned == pytest.approx(90.0, abs=15.0)
    heading = math.radians(lk.yaw_deg())
    along = np.dot(lk.velocity()[:2], [math.cos(heading), math.sin(heading)])
    assert along == pytest.approx(1.8, abs=0.5)


def _pitch_offset_rad(lk: OffboardLink) -> float:
    """True minus estimated pitch of a hovering vehicle, rad (the estimate's tilt error)."""
    true_pitch = float(lk.sim.world.truth.euler_ned_frd_rad[0, 1])
    return true_pitch - float(quat.euler_of(lk.sim.fleet.estimator.r)[0, 1])


def _flown(accel_north_m_s2: float, pitch_offset_rad: float) -> float:
    """North acceleration flown when the tilt for ``accel_north_m_s2`` is held on an estimate
    whose pitch is ``pitch_offset_rad`` below the truth (nose-down pitch is negative)."""
    g = 9.80665
    return -g * math.tan(-math.atan(accel_north_m_s2 / g) + pitch_offset_rad)


def _speed_after_acceleration(v0_m_s: float, accel_m_s2: float, seconds: float) -> float:
    """Speed after ``seconds`` of a commanded acceleration against the Typhoon's drag model."""
    from sitl.vehicles.multirotor import load_airframe

    spec = load_airframe("typhoon_h480")
    linear = spec.motor.rotor_drag_coefficient_n_s_m_rad * 6 * spec.hover_speed_rad_s
    quadratic = spec.fuselage.coefficients_n_s2_m2()[0]
    v, dt = v0_m_s, 1e-3
    for _ in range(round(seconds / dt)):
        v += (accel_m_s2 - (linear * v + quadratic * v * abs(v)) / spec.mass_kg) * dt
    return v


def test_position_with_velocity_feed_forward_and_acceleration(flying):
    lk = flying
    start = lk.ned()
    # set_position_velocity_ned: a moving target with its velocity as feed-forward.
    t0 = lk.sim.time_s

    def moving():
        east = min(lk.sim.time_s - t0, 6.0)
        return local_ned(0x09C0, x=start[0], y=start[1] + east, z=start[2], vy=1.0 * (east < 6))

    lk.stream(moving, 5.0)
    lag = start[1] + (lk.sim.time_s - t0) - lk.ned()[1]
    assert 0.0 < lag < 1.0  # following, and close behind
    lk.stream(moving, 6.0)
    assert np.linalg.norm(lk.ned() - (start + np.array([0.0, 6.0, 0.0]))) < 0.5
    # Horizontal acceleration, height held by a z position (axes mix, as in PX4), 1.5 m/s²
    # north for 3 s, then the same south: not drag-compensated (as in PX4), so the speeds are
    # those of the airframe's drag model (rotor drag at hover speed + parasite drag), integrated.
    # The autopilot tilts its *estimated* attitude: with the full IMU turn-on biases that differs
    # from the true one by the accelerometer bias's tilt (observable only once the vehicle
    # manoeuvres, as for EKF2), so the acceleration actually flown is the commanded one tilted by
    # that pitch offset, measured in the hover before.
    z = start[2]
    offset = _pitch_offset_rad(lk)
    north = local_ned(ACCELERATION_XY_HOLD_Z, z=z, afx=1.5)
    lk.stream(lambda: north, 3.0)
    expected_north = _speed_after_acceleration(0.0, _flown(1.5, offset), 3.0)
    assert lk.velocity()[0] == pytest.approx(expected_north, abs=0.4)
    south = local_ned(ACCELERATION_XY_HOLD_Z, z=z, afx=-1.5)
    lk.stream(lambda: south, 3.0)
    expected_south = _speed_after_acceleration(expected_north, _flown(-1.5, offset), 3.0)
    assert lk.velocity()[0] == pytest.approx(expected_south, abs=0.4)
    assert lk.ned()[2] == pytest.approx(z, abs=0.5)


def test_position_global_relative_altitude(flying):
    lk = flying
    lat, lon = offset_deg(12.0, 5.0)
    sp = mavlink2.MAVLink_set_position_target_global_int_message(
        0, 1, 1, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, POSITION_NED,
        round(lat * 1e7), round(lon * 1e7), 8.0, 0, 0, 0, 0, 0, 0, 0, 0,
    )  # fmt: skip
    lk.stream(lambda: sp, 15.0)
    north, east = lk.ned_of(12.0, 5.0)
    here = lk.ned()
    assert math.hypot(here[0] - north, here[1] - east) < 1.0
    home = lk.commander.home
    assert home.position_ned_m[2] - here[2] == pytest.approx(8.0, abs=0.5)


def test_attitude_and_body_rate_setpoints(flying):
    lk = flying
    hover = float(lk.sim.fleet.hover_thrust[0])  # the learned hover thrust in use
    yaw = lk.yaw_deg()
    # Roll right 15 deg with the thrust that holds the height: accelerate to the right.
    tilt = attitude_target(15.0, 0.0, yaw, hover / math.cos(math.radians(15.0)))
    v0 = lk.velocity()
    lk.stream(lambda: tilt, 2.0)
    right = np.array([-math.sin(math.radians(yaw)), math.cos(math.radians(yaw))])
    gained = lk.velocity() - v0
    assert float(np.dot(gained[:2], right)) > 1.5
    assert abs(gained[2]) < 2.0  # the learned hover thrust is only an estimate
    roll = math.degrees(float(quat.euler_of(lk.sim.fleet.estimator.r)[0, 0]))
    assert roll == pytest.approx(15.0, abs=2.0)
    # Body rates: yaw at 30 deg/s for 2 s.
    spin = mavlink2.MAVLink_set_attitude_target_message(
        0, 1, 1, ATTITUDE_RATE, [1, 0, 0, 0], 0.0, 0.0, math.radians(30), hover
    )
    start_yaw = lk.yaw_deg()
    lk.stream(lambda: spin, 2.0)
    assert (lk.yaw_deg() - start_yaw) % 360.0 == pytest.approx(60.0, abs=10.0)


@pytest.mark.parametrize(
    ("com_obl_rc_act", "main", "sub"),
    [
        (0, AUTO, AutoSubMode.RTL),  # Position mode needs RC: PX4 falls back to Return
        (4, AUTO, AutoSubMode.LAND),
        (5, AUTO, AutoSubMode.LOITER),
    ],
)
def test_losing_the_stream_triggers_com_obl_rc_act(flying, com_obl_rc_act, main, sub):
    lk = flying
    lk.set_param("COM_OBL_RC_ACT", com_obl_rc_act, int32=True)
    here = lk.ned()
    hold = local_ned(POSITION_NED, x=here[0], y=here[1], z=here[2])
    lk.stream(lambda: hold, 1.0)
    lk.run(0.9)  # within COM_OF_LOSS_T (1 s): still Offboard
    assert lk.commander.main_mode == MainMode.OFFBOARD
    lk.run(0.3)
    assert (lk.commander.main_mode, lk.commander.sub_mode) == (main, sub)
    assert any("Offboard signal lost" in t for t in lk.texts)
    # The stream comes back while the failsafe mode is still on: Offboard resumes.
    lk.stream(lambda: hold, 0.5)
    assert lk.commander.main_mode == MainMode.OFFBOARD


def test_a_mode_switch_after_the_loss_is_not_overridden_by_a_returning_stream(flying):
    lk = flying
    lk.set_param("COM_OBL_RC_ACT", 5, int32=True)  # Hold
    here = lk.ned()
    hold = local_ned(POSITION_NED, x=here[0], y=here[1], z=here[2])
    lk.run(1.5)
    assert lk.set_mode(AUTO, AutoSubMode.RTL) == ACCEPTED
    lk.stream(lambda: hold, 1.0)
    assert lk.commander.sub_mode == AutoSubMode.RTL


def test_landing_in_offboard_then_auto_disarm(flying):
    lk = flying
    here = lk.ned()
    down = local_ned(VELOCITY_NED, vz=1.0, yaw=math.radians(lk.yaw_deg()))
    lk.stream(lambda: down, 12.0)
    assert lk.commander.landed_state == LandedState.ON_GROUND
    lk.stream(lambda: down, 4.0)  # COM_DISARM_LAND (2 s) after the landing
    assert not lk.commander.armed
    assert here[2] < lk.ned()[2]


def test_unflyable_setpoints_are_ignored_and_logged_once(flying, caplog):
    lk = flying
    here = lk.ned()
    good = local_ned(POSITION_NED, x=here[0], y=here[1], z=here[2])
    bad = [
        local_ned(0x0FFF, x=here[0] + 50),  # ignores everything
        local_ned(0x0238, x=here[0] + 50),  # accelerations as forces
        local_ned(POSITION_NED, frame=mavlink2.MAV_FRAME_GLOBAL, x=here[0] + 50),
        local_ned(POSITION_NED, x=math.nan),
        attitude_target(0, 0, 0, 0.5, mask=0xC7),  # ignores attitude, rates and thrust
        mavlink2.MAVLink_set_attitude_target_message(0, 1, 1, ATTITUDE, [0, 0, 0, 0], 0, 0, 0, 0.5),
    ]
    stats = lk.sim.endpoints[0].stats
    ignored0 = stats.setpoints_ignored
    with caplog.at_level(logging.WARNING, logger="autopilot_emu"):
        for _ in range(3):
            for msg in bad:
                lk.send(msg)
            lk.stream(lambda: good, 0.5)
    assert stats.setpoints_ignored - ignored0 == 3 * len(bad)
    warnings = [r for r in caplog.records if "ignoring SET_" in r.getMessage()]
    assert len(warnings) == len(bad)  # once per reason
    assert lk.commander.main_mode == MainMode.OFFBOARD
    assert np.linalg.norm(lk.ned() - here) < 0.5
    assert stats.handler_errors == 0


@pytest.mark.parametrize("seed", [5, 17])
def test_hovering_before_the_hover_thrust_is_learned_is_not_a_landing(seed):
    """Straight from the ground into an Offboard hover 5 m up (as the MAVSDK examples fly): the
    vehicle reaches its height before the hover-thrust estimator is valid and hovers on about
    half of MPC_THR_HOVER's 0.5 guess; the land detector must not call that a landing (it cut
    the motors in mid-air before it judged low thrust against the learned value only)."""
    lk = OffboardLink.open(seed=seed)
    try:
        lk.wait_ready()
        assert lk.arm() == ACCEPTED
        start = lk.ned()
        hover = local_ned(POSITION_NED, x=start[0], y=start[1], z=start[2] - 5.0)
        assert lk.start(lambda: hover) == ACCEPTED
        states = []
        for _ in range(24):
            lk.stream(lambda: hover, 0.5)
            states.append(lk.commander.landed_state)
        airborne = states[states.index(LandedState.IN_AIR) :]
        assert LandedState.ON_GROUND not in airborne, states
        assert not any("Landing detected" in t for t in lk.texts)
        assert abs(lk.ned()[2] - (start[2] - 5.0)) < 0.3
    finally:
        lk.close()
