"""Conformance client: offboard control, as MAVSDK-Python's offboard_* examples do it.

    python offboard_conformance.py --api classic|native --url udpin://0.0.0.0:PORT
        [--grpc-port GRPC]

start() without a setpoint first (refused client-side), then arm, a setpoint, start(), and in
turn: position NED (climb, move and turn), velocity NED, body velocity, attitude; then stop()
and land. Each phase holds its setpoint for a window of simulated time and records where the
vehicle went (position_velocity_ned, attitude_euler).
"""

from __future__ import annotations

import argparse
import asyncio
import statistics

from _conformance import SEEN_S, Api, Checks, Report, client_main, collect, outcome

WINDOW_S = 8.0
"""Simulated seconds a position setpoint is held before the vehicle must be there."""
VELOCITY_WINDOW_S = 8.0
"""Simulated seconds a velocity setpoint is held; the last half is averaged. The Typhoon's
rotor drag (Gazebo's coefficient, about 1.2 /s) is cancelled by the velocity integrator, whose
time constant with PX4's default gains (MPC_XY_VEL_P_ACC / MPC_XY_VEL_I_ACC) is about 4.5 s."""
ATTITUDE_WINDOW_S = 2.0


class Offboard:
    def __init__(self, api: Api, checks: Checks) -> None:
        self.api = api
        self.checks = checks
        self.offboard = api.plugin("offboard")
        self.types = api.types("offboard")
        self.origin = (0.0, 0.0, 0.0)

    async def where(self) -> dict:
        """Position relative to the start point (NED, m), velocity and yaw."""
        pv = await self.api.now("position_velocity_ned")
        e = await self.api.now("attitude_euler")
        p = pv.position
        return {
            "ned_m": [p.north_m - self.origin[0], p.east_m - self.origin[1],
                      p.down_m - self.origin[2]],
            "velocity_m_s": [pv.velocity.north_m_s, pv.velocity.east_m_s, pv.velocity.down_m_s],
            "yaw_deg": e.yaw_deg,
            "flight_mode": (await self.api.now("flight_mode")).name,
        }  # fmt: skip

    async def velocity_window(self) -> list[float]:
        """Mean NED velocity over the second half of a velocity window."""
        await self.api.sim_sleep(VELOCITY_WINDOW_S / 2)
        samples: list = []
        task = asyncio.ensure_future(collect(self.api.telemetry("position_velocity_ned"), samples,
                                             lambda pv: pv.velocity))  # fmt: skip
        await self.api.sim_sleep(VELOCITY_WINDOW_S / 2)
        task.cancel()
        return [
            statistics.fmean(getattr(v, axis) for v in samples)
            for axis in ("north_m_s", "east_m_s", "down_m_s")
        ]

    async def flow(self) -> None:
        api, run_check, t, ob = self.api, self.checks.run, self.types, self.offboard

        async def start_without_setpoint() -> dict:
            return {"start": await outcome(ob.start())}

        async def start() -> dict:
            pv = await api.now("position_velocity_ned")
            self.origin = (pv.position.north_m, pv.position.east_m, pv.position.down_m)
            await api.plugin("action").arm()
            await ob.set_position_ned(t.PositionNedYaw(0.0, 0.0, 0.0, 0.0))
            await ob.start()
            mode = await api.until(
                "flight_mode", lambda m: m.name == "OFFBOARD", SEEN_S, "OFFBOARD"
            )
            return {"flight_mode": mode.name, "is_active": await ob.is_active()}

        async def position(north: float, east: float, down: float, yaw: float) -> dict:
            await ob.set_position_ned(t.PositionNedYaw(north, east, down, yaw))
            await api.sim_sleep(WINDOW_S)
            return await self.where()

        async def velocity_ned() -> dict:
            await ob.set_velocity_ned(t.VelocityNedYaw(1.0, 0.0, 0.0, 90.0))
            return {"mean_velocity_m_s": await self.velocity_window(), **await self.where()}

        async def velocity_body() -> dict:
            await ob.set_velocity_body(t.VelocityBodyYawspeed(1.0, 0.0, 0.0, 0.0))
            return {"mean_velocity_m_s": await self.velocity_window(), **await self.where()}

        async def attitude() -> dict:
            hover = await api.plugin("param").get_param_float("MPC_THR_HOVER")
            await ob.set_attitude(t.Attitude(5.0, 0.0, 90.0, hover))
            await api.sim_sleep(ATTITUDE_WINDOW_S)
            e = await api.now("attitude_euler")
            out = {"roll_deg": e.roll_deg, "pitch_deg": e.pitch_deg, "yaw_deg": e.yaw_deg}
            here = await api.now("position_velocity_ned")
            await ob.set_position_ned(t.PositionNedYaw(here.position.north_m - self.origin[0],
                                                       here.position.east_m - self.origin[1],
                                                       -5.0, 90.0))  # fmt: skip
            await api.sim_sleep(3.0)
            return out

        async def stop_and_land() -> dict:
            await ob.stop()
            mode = await api.until("flight_mode", lambda m: m.name == "HOLD", SEEN_S, "HOLD")
            await api.plugin("action").land()
            await api.until("in_air", lambda x: not x, 60, "landed (in_air False)")
            return {"mode_after_stop": mode.name, "is_active": await ob.is_active()}

        await run_check("offboard_start_without_setpoint", start_without_setpoint)
        await run_check("offboard_start", start)
        await run_check("offboard_position_climb", lambda: position(0.0, 0.0, -5.0, 0.0))
        await run_check("offboard_position_move_turn", lambda: position(5.0, 0.0, -5.0, 90.0))
        await run_check("offboard_velocity_ned", velocity_ned)
        await run_check("offboard_velocity_body", velocity_body)
        await run_check("offboard_attitude", attitude)
        await run_check("offboard_stop_land", stop_and_land)


async def flow(api: Api, args: argparse.Namespace, r: Report) -> None:
    checks = Checks(r)
    await checks.group("offboard", Offboard(api, checks).flow)


if __name__ == "__main__":
    client_main(flow, timeout_sim_s=1200.0)
