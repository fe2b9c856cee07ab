"""``swarmsitl up --params``: QGroundControl ``.params`` files onto the vehicles, and back on exit.

Which vehicle a row loads into (``--params`` is repeatable, applied in the order given, a later
value of a parameter wins):

* ``--params FILE``: each row into the vehicle whose system id is the row's Vehicle-Id, as
  QGroundControl loads a file only into the vehicle it was saved from. A fleet file
  (``client_params.params`` of an earlier run) thus restores every vehicle. A row naming a
  vehicle the run does not have is an error.
* ``--params SYSID=FILE``: a one-vehicle file (QGroundControl's "Save to file") into vehicle SYSID,
  whatever id it was saved from.
* ``--params all=FILE``: a one-vehicle file into every vehicle: one tuning for the whole swarm.

Only the autopilot's rows (component 1) load; rows of other components (a camera, a gimbal) are
skipped and counted. MAV_SYS_ID rows are skipped too: vehicle i of a run is always system i+1.
Rows reach the vehicles as ``SimulationConfig.vehicle_params``, which the simulation writes into
each vehicle's parameter store after the airframe's and the world's parameters.

On exit the simulation saves what MAVLink clients set (PARAM_SET) to ``client_params.params`` in
the run directory (:func:`save_client_params`), a fleet file that ``--params`` takes back.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from autopilot_emu.param_file import (
    AUTOPILOT_COMPONENT_ID,
    ParamFileError,
    format_param_file,
    read_param_file,
    store_rows,
)
from autopilot_emu.params import ParamStore, ParamValue

log = logging.getLogger(__name__)

CLIENT_PARAMS_FILE = "client_params.params"
"""File of the run directory holding the parameters MAVLink clients set during the run."""
ALL_VEHICLES = "all"
"""``--params all=FILE``: the file's rows into every vehicle."""
PARAMS_HELP = (
    "load a QGroundControl .params file: FILE (each row into the vehicle whose id it names), "
    "SYSID=FILE (a one-vehicle file into vehicle SYSID) or all=FILE (into every vehicle); "
    "repeatable, later wins; e.g. all=tuning.params"
)
_SKIPPED_NAMES = frozenset({"MAV_SYS_ID"})


@dataclass(frozen=True)
class ParamsLoad:
    """What the ``--params`` options load."""

    vehicle_params: tuple[dict[str, ParamValue], ...]
    """Name -> value for each vehicle, in vehicle order (``SimulationConfig.vehicle_params``)."""
    notes: tuple[str, ...]
    """One line per file with skipped rows (other components, MAV_SYS_ID)."""
    files: tuple[Path, ...]
    """The files loaded, in the order given."""


def parse_params_option(spec: str) -> tuple[int | str | None, Path]:
    """``FILE``, ``SYSID=FILE`` or ``all=FILE`` -> (None | SYSID | "all", path)."""
    target, sep, rest = spec.partition("=")
    if sep and target.strip().lower() == ALL_VEHICLES:
        return ALL_VEHICLES, Path(rest)
    if sep and target.strip().isdigit():
        return int(target), Path(rest)
    return None, Path(spec)


def load_params_options(specs: Sequence[str], n_vehicles: int) -> ParamsLoad:
    """Read and check every ``--params`` file; ValueError (ParamFileError) naming file and line."""
    per_vehicle: list[dict[str, ParamValue]] = [{} for _ in range(n_vehicles)]
    notes = []
    files = []
    for spec in specs:
        target, path = parse_params_option(spec)
        if isinstance(target, int) and not 1 <= target <= n_vehicles:
            raise ValueError(
                f"--params {spec}: no vehicle {target} in this run (vehicles 1..{n_vehicles})"
            )
        rows = read_param_file(path)
        files.append(path)
        skipped: Counter[str] = Counter()
        first_vehicle: tuple[int, int] | None = None
        for row in rows:
            if row.component_id != AUTOPILOT_COMPONENT_ID:
                skipped[f"component {row.component_id}"] += 1
                continue
            if target is not None:
                if first_vehicle is None:
                    first_vehicle = (row.vehicle_id, row.line)
                elif row.vehicle_id != first_vehicle[0]:
                    raise ParamFileError(
                        str(path),
                        row.line,
                        f"vehicle id {row.vehicle_id}, but line {first_vehicle[1]} names "
                        f"{first_vehicle[0]}: {target}=FILE takes a one-vehicle file (give a "
                        "fleet file without SYSID= or all= to load each row into its vehicle)",
                    )
            elif not 1 <= row.vehicle_id <= n_vehicles:
                raise ParamFileError(
                    str(path),
                    row.line,
                    f"vehicle id {row.vehicle_id}, but this run has vehicles 1..{n_vehicles} (to "
                    f"load one vehicle's file into others: --params SYSID={path} or all={path})",
                )
            if row.name in _SKIPPED_NAMES:
                skipped[row.name] += 1
                continue
            if target == ALL_VEHICLES:
                indices = range(n_vehicles)
            elif isinstance(target, int):
                indices = range(target - 1, target)
            else:
                indices = range(row.vehicle_id - 1, row.vehicle_id)
            for i in indices:
                per_vehicle[i][row.name] = row.value
        if skipped:
            what = ", ".join(f"{count} of {name}" for name, count in sorted(skipped.items()))
            notes.append(
                f"{path}: skipped {sum(skipped.values())} row(s) ({what}): only the autopilot's "
                "(component 1) load, and system ids follow the vehicle order"
            )
    return ParamsLoad(tuple(per_vehicle), tuple(notes), tuple(files))


def save_client_params(
    out_dir: Path, stores: Sequence[ParamStore], first_sysid: int = 1
) -> Path | None:
    """Write the parameters MAVLink clients set to ``out_dir/client_params.params``.

    Vehicle i's rows carry system id ``first_sysid`` + i. Never raises: this runs while a run
    closes, after its tlogs and recordings are written, and a failure (a full disk) is logged and
    returns None.
    """
    path = out_dir / CLIENT_PARAMS_FILE
    try:
        rows = [
            row
            for i, store in enumerate(stores)
            for row in store_rows(first_sysid + i, store, store.client_set)
        ]
        text = format_param_file(
            rows,
            comments=(
                "Parameters MAVLink clients set (PARAM_SET) during a swarmsitl run, final values.",
                "Start the next run from them: swarmsitl up --params THIS_FILE",
            ),
        )
        path.write_text(text)
    except Exception as exc:  # a run's closing must not fail on this file
        log.error("could not save the client-set parameters to %s: %s", path, exc)
        return None
    return path
