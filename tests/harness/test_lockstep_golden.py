"""A fixed seed's lockstep trajectory against a recording made before the kernels were compiled.

Issue 12 compiles the per-tick kernels (estimator, controllers, mixer, rotors, sensors) and
shortens the Python around them; it must not change behaviour. The recording in
``data/lockstep_golden.npz`` was made with the uncompiled numpy code (commit before issue 12's
first change). Compiled code may reassociate floating-point sums (fused multiply-adds, loop
order), so the comparison allows a tolerance instead of bit equality, in two tiers:

* **until 6 s** (boot, arming, the start of the climb: continuous dynamics only) the trajectories
  agree to ``TIGHT``: 1 um in position, 1 um/s, 1e-6 in the quaternion, 1e-4 rad/s of rotor speed.
  Reassociation leaves differences of ~1e-10 there; any behaviour change (a gain, a dropped
  sample, a reordered noise draw) moves them by far more within a few ticks.
* **over the whole flight** they agree to ``TOLERANCE``: 1 cm, 1 cm/s, 1e-3, 3 rad/s (0.5 % of the
  hover speed). Later a 1e-10 difference can grow: the jerk-limited trajectory's
  ``a = sqrt(j |e|)`` (``autopilot_emu/control/trajectory.py``) has unbounded gain as the error
  e goes to zero on arrival, and a discrete event moved by one tick (a gust starting) is carried
  on by the closed loop. One changed rounding in the numpy code (``q / n`` as ``q * (1 / n)``)
  moves a flight by 3.5 mm and 1.2 rad/s; with every kernel compiled the worst seen was 2.5 mm
  and 1.6 rad/s, bounded (it does not grow with flight time).

Re-recorded at issue 13, when behaviour was meant to change twice: the HIL messages carry
float32 values in memory as on the wire (so that the TCP mode flies the very same flight,
``tests/harness/test_external_autopilot.py``), and each vehicle's mixer decides saturation on its
own (it was decided for the whole fleet, which coupled vehicles). Against the previous recording
the calm Typhoons moved by at most 2.8 mm (float32 rounding); the mixed fleet by 1.2 cm and
197 rad/s of rotor speed at spool-up, where the x500's saturation had been desaturating the
Typhoons' outputs.

Re-recorded at issue 28, when behaviour was meant to change: PX4's allocation normalisation,
THR_MDL_FAC 0, the gyro and D-term filters, MPC_YAWRAUTO_MAX, the x500's MPC_THR_HOVER and the
GNSS receivers of the sensor catalogue (NEO-M9N, 1.27 m per axis instead of ~0.35 m).

Regenerate (only when behaviour is meant to change, and say so in the commit):
``python tests/harness/test_lockstep_golden.py --record``.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pymap3d
import pytest

from harness.sim.simulation import Simulation, SimulationConfig
from sitl.physics.wind import WindConfig
from sitl.world import WorldConfig

GOLDEN = Path(__file__).parent / "data" / "lockstep_golden.npz"
SAMPLE_EVERY_S = 0.1
TAKEOFF_AT_S = 2.0
GOTO_AT_S = 8.0
END_S = 14.0

SCENARIOS: dict[str, dict] = {
    # One airframe (the world's single-group fast path), calm air.
    "typhoon_calm": {"n_vehicles": 2, "frames": ("typhoon_h480",), "wind": None},
    # Two airframes (per-group path), steady wind with turbulence and gusts, rangefinders.
    "mixed_wind": {
        "n_vehicles": 3,
        "frames": ("typhoon_h480", "x500", "typhoon_h480"),
        "wind": WindConfig(speed_m_s=4.0, from_deg=60.0, turbulence_w20_m_s=2.0, gust_peak_m_s=2.0),
        "world": WorldConfig(n_vehicles=3, rangefinders=True),
    },
}
TIGHT_UNTIL_S = 6.0
TIGHT = {
    "position_enu_m": 1e-6,
    "velocity_enu_m_s": 1e-6,
    "quaternion_xyzw": 1e-6,
    "rotor_speed_rad_s": 1e-4,
    "estimated_position_ned_m": 1e-6,
}
TOLERANCE = {
    "position_enu_m": 1e-2,
    "velocity_enu_m_s": 1e-2,
    "quaternion_xyzw": 1e-3,
    "rotor_speed_rad_s": 3.0,
    "estimated_position_ned_m": 1e-2,
}


def fly(name: str) -> dict[str, np.ndarray]:
    """Fly scenario ``name`` in lockstep; return its samples stacked over time."""
    spec = SCENARIOS[name]
    cfg = SimulationConfig(
        n_vehicles=spec["n_vehicles"],
        frames=spec["frames"],
        seed=7,
        mavlink=False,
        record_hz=0.0,
        wind=spec["wind"],
        world=spec.get("world"),
        mocap_port=0,
    )
    samples: dict[str, list[np.ndarray]] = {k: [] for k in TOLERANCE}
    with Simulation(cfg) as sim:
        vehicles = [sim.fleet.vehicle(i) for i in range(cfg.n_vehicles)]

        def sample() -> None:
            truth = sim.world.truth
            samples["position_enu_m"].append(truth.position_enu_m)
            samples["velocity_enu_m_s"].append(truth.velocity_enu_m_s)
            samples["quaternion_xyzw"].append(truth.quaternion_xyzw)
            samples["rotor_speed_rad_s"].append(truth.rotor_speed_rad_s)
            samples["estimated_position_ned_m"].append(sim.fleet.estimator.position_ned_m.copy())

        def run_until(t_s: float) -> None:
            while sim.time_s < t_s - 1e-9:
                sim.run_lockstep(SAMPLE_EVERY_S)
                sample()

        run_until(TAKEOFF_AT_S)
        for v in vehicles:
            v.arm(False)
            v.takeoff(None)
        run_until(GOTO_AT_S)
        for v in vehicles:
            tel = v.telemetry()
            assert tel.home is not None
            lat, lon, _ = pymap3d.ned2geodetic(
                10.0, 5.0, 0.0, tel.home.lat_deg, tel.home.lon_deg, tel.home.alt_amsl_m
            )
            v.reposition(float(lat), float(lon), tel.alt_amsl_m, 0.0, math.nan)
        run_until(END_S)
    return {k: np.stack(v) for k, v in samples.items()}


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_lockstep_trajectory_matches_the_recording(name: str) -> None:
    """Flying a fixed seed reproduces the recording made with the uncompiled code."""
    recorded = np.load(GOLDEN)
    flown = fly(name)
    # The scenario really flew: it climbed and moved (else the comparison proves little).
    pos = flown["position_enu_m"]
    assert (pos[-1, :, 2] - pos[0, :, 2]).min() > 1.5
    assert (pos[-1, :, 1] - pos[0, :, 1]).min() > 5.0
    tight_samples = round(TIGHT_UNTIL_S / SAMPLE_EVERY_S)
    for key, tol in TOLERANCE.items():
        want = recorded[f"{name}/{key}"]
        got = flown[key]
        assert got.shape == want.shape, key
        early = float(np.max(np.abs(got[:tight_samples] - want[:tight_samples])))
        assert early <= TIGHT[key], (
            f"{name} {key}: differs from the recording by {early:.3g} > {TIGHT[key]} "
            f"in the first {TIGHT_UNTIL_S:g} s"
        )
        worst = float(np.max(np.abs(got - want)))
        assert worst <= tol, f"{name} {key}: differs from the recording by {worst:.3g} > {tol}"


def _record() -> None:
    GOLDEN.parent.mkdir(parents=True, exist_ok=True)
    arrays = {}
    for name in SCENARIOS:
        for key, values in fly(name).items():
            arrays[f"{name}/{key}"] = values
    np.savez_compressed(GOLDEN, **arrays)
    print(f"wrote {GOLDEN}")


if __name__ == "__main__":
    if sys.argv[1:] != ["--record"]:
        raise SystemExit("usage: python tests/harness/test_lockstep_golden.py --record")
    _record()
