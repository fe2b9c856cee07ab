"""The airframes' budgets beside the published aircraft: the table of docs/airframes.md.

Every "ours" number is computed here from the airframe files and the models that fly them
(:func:`sitl.vehicles.budget.airframe_budget`): hover in ISA air (sea level unless ``--alt-m``;
the simulated worlds default to 488 m) with the avionics load,
the pack drained at that power to PX4's low-battery reserve (BAT_LOW_THR, read from the emulated
autopilot's parameter defaults) and to the low-voltage cutoff, the drag model's level flight at
the identification tilt (35 deg, below MPC_TILTMAX_AIR). The reference column holds the published
figures of the Yuneec Typhoon H, with their sources below the table; no airframe is flown
(``benchmarks/flight_envelope.py`` flies them).

    python benchmarks/airframe_budget.py
    python benchmarks/airframe_budget.py --frames typhoon_h480_yuneec --alt-m 488
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass

from autopilot_emu.params import ParamStore
from sitl.physics.earth import isa_pressure_pa, isa_temperature_k
from sitl.vehicles.budget import AirframeBudget, BudgetConditions, airframe_budget
from sitl.vehicles.multirotor import load_airframe

FRAMES = ("typhoon_h480", "typhoon_h480_yuneec", "x500")

YUNEEC_MASS_KG = 1.695
"""Take-off weight with battery and CGO3+ camera, 1695 g [Yuneec]."""
YUNEEC_PACK_WH = 79.9
"""Battery: LiPo 4S 5400 mAh 14.8 V 79.9 Wh [Yuneec]."""
YUNEEC_FLIGHT_TIME_MIN = 25.0
"""Flight time "up to 25 min" [Yuneec], taken as hover from full to PX4's low-battery reserve."""
YUNEEC_TOP_SPEED_M_S = 70.0 / 3.6
"""Maximum flight speed 70 km/h [Yuneec]."""
DESIGN_THRUST_TO_WEIGHT = 2.0
"""The usual design margin of a camera multirotor (assumed; Yuneec publishes no motor data)."""

SOURCES = (
    "[Yuneec] Yuneec Typhoon H (H480) specifications: take-off weight 1695 g, battery 4S 5400 mAh "
    "79.9 Wh, flight time up to 25 min, maximum speed 70 km/h.",
    "[implied] 79.9 Wh x (1 - BAT_LOW_THR) / 25 min: the mean power that empties the published "
    "pack's nominal energy to the reserve in the published time (the pack model holds more "
    "energy, see 'pack energy').",
    "[assumed] thrust/weight 2: design margin, assumed (typhoon_h480_yuneec.yaml, motor).",
    "[power model] shaft torque / thrust at hover = (eta P_e / w_h) / T_h of the airframe's own "
    "power model: the physical value of k_m.",
)


@dataclass(frozen=True)
class Row:
    """One quantity of the table."""

    label: str
    value: Callable[[AirframeBudget], float]
    fmt: str
    reference: str


def rows(reserve_soc: float) -> list[Row]:
    """The table's quantities, with the reference of each (published, implied or assumed)."""
    implied_w = YUNEEC_PACK_WH * (1.0 - reserve_soc) * 60.0 / YUNEEC_FLIGHT_TIME_MIN
    return [
        Row("mass, kg", lambda b: b.mass_kg, "{:.3f}", f"{YUNEEC_MASS_KG:.3f} [Yuneec]"),
        Row("hover rotor speed, rad/s", lambda b: b.hover_speed_rad_s, "{:.0f}", "-"),
        Row("hover command (w_h / w_max)", lambda b: b.hover_command, "{:.2f}", "-"),
        Row(
            "hover power (rotors + 3 W avionics), W",
            lambda b: b.hover_power_w,
            "{:.1f}",
            f"~{implied_w:.0f} [implied]",
        ),
        Row("FM x motor/ESC efficiency", lambda b: b.propulsive_efficiency, "{:.3f}", "-"),
        Row(
            "pack energy (model, full to empty), Wh",
            lambda b: b.pack_energy_wh,
            "{:.1f}",
            f"{YUNEEC_PACK_WH:.1f} [Yuneec]",
        ),
        Row(
            f"endurance to low battery ({reserve_soc:.0%} left), min",
            lambda b: b.endurance_to_reserve_s / 60.0,
            "{:.2f}",
            f"{YUNEEC_FLIGHT_TIME_MIN:.0f} [Yuneec]",
        ),
        Row(
            "endurance to cutoff (3.0 V/cell), min",
            lambda b: b.endurance_to_cutoff_s / 60.0,
            "{:.2f}",
            "-",
        ),
        Row(
            "top speed (level flight at 35 deg, sea level), m/s",
            lambda b: b.top_speed_m_s,
            "{:.2f}",
            f"{YUNEEC_TOP_SPEED_M_S:.2f} = 70 km/h [Yuneec]",
        ),
        Row(
            "thrust/weight (full pack)",
            lambda b: b.thrust_to_weight,
            "{:.2f}",
            f"{DESIGN_THRUST_TO_WEIGHT:.0f} [assumed]",
        ),
        Row(
            "k_m (motor model), m",
            lambda b: b.moment_coefficient_m,
            "{:.4f}",
            "shaft torque / thrust [power model]",
        ),
        Row(
            "shaft torque / thrust at hover, m",
            lambda b: b.shaft_torque_per_thrust_m,
            "{:.4f}",
            "-",
        ),
    ]


def table(frames: tuple[str, ...], conditions: BudgetConditions) -> str:
    """The Markdown table: one row per quantity, one column per airframe, then the reference."""
    budgets = [airframe_budget(load_airframe(name), conditions) for name in frames]
    head = ["quantity", *frames, "reference (Yuneec Typhoon H)"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in rows(conditions.reserve_soc):
        cells = [row.fmt.format(row.value(b)) for b in budgets]
        lines.append("| " + " | ".join([row.label, *cells, row.reference]) + " |")
    return "\n".join(lines)


def main() -> None:
    """Print the table for the airframes asked for, with its conditions and sources."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", default=",".join(FRAMES), help="comma-separated airframes")
    ap.add_argument(
        "--alt-m", type=float, default=0.0, help="altitude AMSL of the hover (ISA air), m"
    )
    args = ap.parse_args()
    params = ParamStore()
    reserve = float(params.get("BAT_LOW_THR"))
    tilt_max = float(params.get("MPC_TILTMAX_AIR"))
    rho = float(isa_pressure_pa(args.alt_m) / (287.05 * isa_temperature_k(args.alt_m)))
    conditions = BudgetConditions(reserve_soc=reserve, air_density_kg_m3=rho)
    if conditions.top_speed_tilt_deg >= tilt_max:
        raise SystemExit(f"top-speed tilt {conditions.top_speed_tilt_deg} >= MPC_TILTMAX_AIR")
    print(
        f"Hover at {args.alt_m:g} m AMSL in ISA air (rho {rho:.4f} kg/m^3), loads "
        f"{conditions.loads_w:g} W, reserve BAT_LOW_THR = {reserve:g}, top speed at "
        f"{conditions.top_speed_tilt_deg:g} deg (MPC_TILTMAX_AIR {tilt_max:g} deg).\n"
    )
    print(table(tuple(args.frames.split(",")), conditions))
    print()
    for source in SOURCES:
        print(f"- {source}")


if __name__ == "__main__":
    main()
