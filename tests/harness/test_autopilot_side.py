"""The two autopilot sides of a physics step: what each receives, in which order, and returns."""

from __future__ import annotations

from harness.sim.autopilot_side import FleetSide, HilSide, Readings

READINGS = Readings(sensors=["imu"], gps=["fix"], battery=["pack"], ranges=["range"])


class Recorder:
    """Records every call as (name, argument)."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, object]] = []

    def _record(self, name: str, value: object = None) -> None:
        self.calls.append((name, value))


class FakeFleet(Recorder):
    def handle_gps(self, msgs):
        self._record("gps", msgs)

    def handle_sensors(self, msgs):
        self._record("sensors", msgs)
        return ["actuators"]

    def handle_battery(self, msgs):
        self._record("battery", msgs)

    def handle_distance_sensors(self, msgs):
        self._record("ranges", msgs)


class FakeHil(Recorder):
    def send_gps(self, msgs):
        self._record("gps", msgs)

    def send_sensors(self, msgs):
        self._record("sensors", msgs)

    def send_battery(self, msgs):
        self._record("battery", msgs)

    def send_distance_sensors(self, msgs):
        self._record("ranges", msgs)

    def send_state(self, now_s, truth):
        self._record("state", (now_s, truth()))

    def actuators(self):
        self._record("actuators")
        return ["replies"]


def test_the_fleet_handles_gps_then_the_imu_then_battery_and_ranges():
    """The order ``Simulation.step`` always had: a fix is fused before the IMU step it precedes."""
    fleet = FakeFleet()
    side = FleetSide(fleet)
    side.deliver(READINGS, 1.0, lambda: "truth")
    assert fleet.calls == [("gps", ["fix"]), ("sensors", ["imu"]), ("battery", ["pack"]),
                           ("ranges", ["range"])]  # fmt: skip
    assert side.actuators() == ["actuators"]
    assert side.actuators() is None  # handed out once: a step without an IMU sample keeps them


def test_without_an_imu_sample_the_fleet_commands_nothing_new():
    fleet = FakeFleet()
    side = FleetSide(fleet)
    side.deliver(Readings(sensors=None, gps=None, battery=["pack"], ranges=None), 1.0, lambda: 0)
    assert fleet.calls == [("battery", ["pack"])]
    assert side.actuators() is None


def test_an_external_autopilot_gets_the_readings_then_the_truth_and_is_waited_for():
    hil = FakeHil()
    side = HilSide(hil)
    side.deliver(READINGS, 2.5, lambda: "truth")
    assert [name for name, _ in hil.calls] == ["gps", "sensors", "battery", "ranges", "state"]
    assert hil.calls[-1] == ("state", (2.5, "truth"))
    assert side.actuators() == ["replies"]
