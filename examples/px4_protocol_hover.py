"""A raw pymavlink script as a vehicle's autopilot: PX4's TCP simulator protocol, nothing of ours.

It shows that ``swarmsitl up --autopilot external`` speaks PX4's protocol and not a private
one: this script uses only pymavlink, as PX4's ``simulator_mavlink`` uses only the MAVLink C
library. It connects to the simulator's TCP port of the vehicle, greets it as PX4 does (one
HEARTBEAT, then MAV_CMD_SET_MESSAGE_INTERVAL asking for HIL_STATE_QUATERNION every 5 ms), and
answers every HIL_SENSOR with a HIL_ACTUATOR_CONTROLS (armed, lockstep flag): all motors at one
command from a PID on the ground-truth altitude plus a PD attitude hold through the Typhoon H480's
motor geometry (PX4's airframe 6011, the outputs in PX4's order), so the vehicle climbs to
``--alt`` and hovers level.

    swarmsitl up --autopilot external --lockstep     # one terminal: the simulator waits
    python examples/px4_protocol_hover.py --alt 3    # another: fly 20 simulated seconds

It prints one JSON line: the highest and the final altitude above the start, the tilt, and the
message counts.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time

os.environ.setdefault("MAVLINK20", "1")  # PX4 speaks MAVLink 2 to its simulator

from pymavlink import mavutil

MAV = mavutil.mavlink
ARMED = MAV.MAV_MODE_FLAG_SAFETY_ARMED | MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
LOCKSTEP = 1  # HIL_ACTUATOR_CONTROLS flags bit 0
TYPHOON = (  # PX4 airframe 6011: (CA_ROTORn_PX, CA_ROTORn_PY, sign of CA_ROTORn_KM), outputs 1..6
    (0.0, 1.0, -1), (0.0, -1.0, 1), (0.866, -0.5, -1),
    (-0.866, 0.5, 1), (0.866, 0.5, 1), (-0.866, -0.5, -1),
)  # fmt: skip


def mix(thrust: float, roll: float, pitch: float, yaw: float) -> list[float]:
    """Motor outputs 0..1 for a collective command and roll/pitch/yaw commands (FRD torques)."""
    out = [thrust - roll * py + pitch * px + yaw * km for px, py, km in TYPHOON]
    return [max(0.0, min(1.0, u)) for u in out] + [0.0] * (16 - len(out))


def main() -> None:
    """Connect, greet as PX4, answer every HIL_SENSOR until --seconds, print the result."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--connect", default="tcp:127.0.0.1:4560", help="the simulator's port")
    ap.add_argument("--alt", type=float, default=3.0, help="hover height above the start, m")
    ap.add_argument("--seconds", type=float, default=20.0, help="simulated seconds to fly")
    ap.add_argument("--wait", type=float, default=60.0, help="wall seconds to wait for it")
    args = ap.parse_args()

    deadline = time.monotonic() + args.wait
    while True:  # as PX4: retry until the simulator accepts
        try:
            sim = mavutil.mavlink_connection(args.connect, source_system=1, source_component=1)
            break
        except ConnectionRefusedError:
            if time.monotonic() > deadline:
                raise SystemExit(f"no simulator at {args.connect} after {args.wait:g} s") from None
            time.sleep(0.5)
    sim.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GENERIC, mavutil.mavlink.MAV_AUTOPILOT_PX4,
                           0, 0, 0)  # fmt: skip
    sim.mav.command_long_send(0, 0, mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                              mavutil.mavlink.MAVLINK_MSG_ID_HIL_STATE_QUATERNION, 5000,
                              0, 0, 0, 0, 0)  # fmt: skip

    start_alt = alt = climb = None
    t0 = t_prev = None
    integral, highest, tilt_deg = 0.0, 0.0, 0.0
    roll = pitch = 0.0
    counts = {"HIL_SENSOR": 0, "HIL_STATE_QUATERNION": 0, "HIL_GPS": 0}
    while True:
        msg = sim.recv_match(blocking=True, timeout=30)
        if msg is None:
            raise SystemExit("no message from the simulator for 30 s")
        kind = msg.get_type()
        if kind in counts:
            counts[kind] += 1
        if kind == "HIL_STATE_QUATERNION":
            alt, climb = msg.alt * 1e-3, -msg.vz * 1e-2
            if start_alt is None:
                start_alt = alt
            w, x, y, z = msg.attitude_quaternion
            roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
            pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
            tilt_deg = math.degrees(math.acos(max(-1.0, min(1.0, 1 - 2 * (x * x + y * y)))))
            highest = max(highest, alt - start_alt)
        elif kind == "HIL_SENSOR":
            t = msg.time_usec * 1e-6
            t0 = t if t0 is None else t0
            dt = 0.0 if t_prev is None else t - t_prev
            t_prev = t
            controls = [0.0] * 16
            if start_alt is not None:
                error = args.alt - (alt - start_alt)
                integral = max(-2.0, min(2.0, integral + error * dt))
                thrust = max(0.1, min(0.9, 0.55 + 0.08 * error - 0.12 * climb + 0.05 * integral))
                controls = mix(
                    thrust,
                    -(0.3 * roll + 0.06 * msg.xgyro),  # gyro: body rates, rad/s
                    -(0.3 * pitch + 0.06 * msg.ygyro),
                    -0.05 * msg.zgyro,
                )
            sim.mav.hil_actuator_controls_send(msg.time_usec, controls, ARMED, LOCKSTEP)
            if t - t0 >= args.seconds:
                break
    sim.close()
    print(json.dumps({
        "highest_m": round(highest, 3),
        "final_m": round(alt - start_alt, 3) if start_alt is not None else None,
        "tilt_deg": round(tilt_deg, 2),
        **counts,
    }))  # fmt: skip


if __name__ == "__main__":
    main()
