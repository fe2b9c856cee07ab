"""Flight envelope of each airframe, measured by flying it: hover power, endurance, speeds.

For every airframe the whole stack flies in lockstep (no sockets): take off, hover, an 80 m goto
at MPC_XY_CRUISE, then an offboard velocity setpoint far above what the airframe can fly, with the
tilt limit MPC_TILTMAX_AIR set to the published-top-speed tilt (35 deg) and MPC_XY_VEL_MAX at its
maximum (20 m/s). Every number comes from the simulator's ground truth:

- hover power: mean electrical power (rotors + avionics) over 5 s of hover, W;
- endurance: the LiPo model of the airframe's pack integrated at that power until cutoff, min;
- cruise: median ground speed over the middle 40 % of the goto leg, against MPC_XY_CRUISE;
- top speed: mean ground speed over the last 5 s of the full-speed run, with its mean tilt, and
  the drag model's closed-form level-flight speed at that tilt for comparison.

    python benchmarks/flight_envelope.py            # the three shipped airframes, seed 0
    python benchmarks/flight_envelope.py --frames x500 --seed 3

The last line is ``RESULT key=value ...`` (per airframe: hover_w, endurance_min, cruise_m_s,
top_speed_m_s, top_tilt_deg).
"""

from __future__ import annotations

import argparse
import math
import platform
import time
from collections.abc import Callable

import numpy as np

from autopilot_emu.modes import MainMode
from autopilot_emu.modes.offboard import LocalFrame, OffboardSetpoint
from harness.sim.simulation import Simulation, SimulationConfig
from sitl.power.battery import endurance_s

TILT_LIMIT_DEG = 35.0
"""MPC_TILTMAX_AIR for the top-speed run: the tilt at which the drag model was identified."""
GOTO_M = 80.0


def _truth_rows(
    sim: Simulation, seconds: float, each: Callable[[], None] | None = None
) -> np.ndarray:
    """(t, north, east, speed_h, tilt, electrical W) every 0.1 s of simulation time."""
    rows = []
    t0 = sim.time_s
    while sim.time_s - t0 < seconds - 1e-9:
        if each is not None:
            each()
        sim.run_lockstep(0.1)
        tr = sim.world.truth
        e, n, _ = tr.position_enu_m[0]
        ve, vn, _ = tr.velocity_enu_m_s[0]
        rows.append((tr.time_s, n, e, math.hypot(ve, vn), tr.tilt_rad[0],
                     tr.electrical_power_w[0]))  # fmt: skip
    return np.array(rows)


def fly(frame: str, seed: int) -> dict[str, float]:
    """Fly one airframe through hover, goto and a full-speed run; return its envelope."""
    sim = Simulation(
        SimulationConfig(n_vehicles=1, mavlink=False, record_hz=0, seed=seed, frames=(frame,))
    )
    try:
        params = sim.fleet.params[0]
        v = sim.fleet.vehicle(0)
        sim.run_lockstep(3.0)
        if v.arm(False) != 0 or v.takeoff(None) != 0:
            raise RuntimeError(f"{frame}: arming or takeoff refused")
        sim.run_lockstep(12.0)
        hover = _truth_rows(sim, 5.0)
        hover_w = float(hover[:, 5].mean())
        pack = sim.world.power.spec.battery

        cruise = float(params.get("MPC_XY_CRUISE"))
        est = sim.fleet.estimator
        lat, lon, alt = est.origin_lla[0]
        north0, east0, down0 = est.position_ned_m[0]
        goal_n = north0 + GOTO_M
        lat_goal = lat + math.degrees(goal_n / 6_378_137.0)
        lon_goal = lon + math.degrees(east0 / (6_378_137.0 * math.cos(math.radians(lat))))
        if v.reposition(lat_goal, lon_goal, alt - down0, math.nan, -1.0) != 0:
            raise RuntimeError(f"{frame}: reposition refused")
        start = sim.world.truth.position_enu_m[0, 1]
        leg = _truth_rows(sim, GOTO_M / cruise + 15.0)
        progress = leg[:, 1] - start
        middle = (progress > 0.3 * GOTO_M) & (progress < 0.7 * GOTO_M)
        cruise_m_s = float(np.median(leg[middle, 3]))

        params.set("MPC_TILTMAX_AIR", TILT_LIMIT_DEG)
        params.set("MPC_XY_VEL_MAX", 20.0)
        setpoint = OffboardSetpoint(velocity_ned_m_s=np.array([30.0, 0.0, 0.0]))

        def send() -> None:
            v.offboard_setpoint(setpoint, LocalFrame.LOCAL_NED)

        send()
        if v.set_mode(MainMode.OFFBOARD, 0) != 0:
            raise RuntimeError(f"{frame}: offboard refused")
        run = _truth_rows(sim, 25.0, each=send)
        last = run[-50:]
        top = float(last[:, 3].mean())
        tilt = float(last[:, 4].mean())
        spec = sim.world.airframe
        closed = spec.level_flight(tilt).speed_m_s
        return {
            "mass_kg": spec.mass_kg,
            "hover_w": hover_w,
            "endurance_min": endurance_s(pack, hover_w) / 60.0,
            "cruise_param_m_s": cruise,
            "cruise_m_s": cruise_m_s,
            "top_speed_m_s": top,
            "top_tilt_deg": math.degrees(tilt),
            "closed_form_m_s": closed,
        }
    finally:
        sim.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument(
        "--frames",
        default="typhoon_h480,typhoon_h480_yuneec,x500",
        help="comma-separated airframes",
    )
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    cpu = platform.processor() or platform.machine()
    print(f"machine: {cpu}; Python {platform.python_version()}; numpy {np.__version__}")
    print(f"{'airframe':<14}{'mass kg':>8}{'hover W':>9}{'endur. min':>11}{'cruise':>14}"
          f"{'top m/s':>9}{'tilt deg':>9}{'closed form':>12}{'wall s':>8}")  # fmt: skip
    result = []
    for frame in args.frames.split(","):
        t0 = time.perf_counter()
        r = fly(frame.strip(), args.seed)
        wall = time.perf_counter() - t0
        print(
            f"{frame:<14}{r['mass_kg']:>8.3f}{r['hover_w']:>9.1f}{r['endurance_min']:>11.1f}"
            f"{r['cruise_m_s']:>7.2f}/{r['cruise_param_m_s']:<6.1f}{r['top_speed_m_s']:>9.2f}"
            f"{r['top_tilt_deg']:>9.1f}{r['closed_form_m_s']:>12.2f}{wall:>8.1f}"
        )
        for key in ("hover_w", "endurance_min", "cruise_m_s", "top_speed_m_s", "top_tilt_deg"):
            result.append(f"{frame}_{key}={r[key]:.2f}")
    print("RESULT " + " ".join(result))


if __name__ == "__main__":
    main()
