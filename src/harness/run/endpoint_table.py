"""``swarmsitl up``'s start-up table: where each vehicle's MAVLink links listen and send.

The table is what a user copies URLs and ports from, so no cell may be cut short. One line per
vehicle needs about 150 columns; in a narrower terminal (80 columns is common) rich truncated the
URLs with an ellipsis. :func:`endpoint_table` keeps the one-line layout when it fits and
otherwise stacks each vehicle's endpoints as labelled lines, every address on one line.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from rich.console import Console
from rich.table import Table

CAPTION = "links: address the vehicle listens on -> address it sends to"
"""What the ``A -> B`` cells mean."""


@dataclass(frozen=True)
class VehicleEndpoints:
    """One vehicle's entries in the table, already formatted."""

    sysid: int
    airframe: str
    onboard: str
    """Onboard link, ``listen -> send``, e.g. ``127.0.0.1:14580 -> 127.0.0.1:14540``."""
    mavsdk: str
    """The URL MAVSDK connects with, e.g. ``udpin://0.0.0.0:14540``."""
    gcs: str
    """Ground-station link, ``listen -> send``, or ``off``."""
    home: str
    """Home position, ``lat, lon, alt``."""
    models: str | None = None
    """Link models ``onboard / GCS`` when a link is modelled, else None (no column)."""
    serial: str | None = None
    """Serial port (``--serial``), else None (no column)."""
    udp_out: str | None = None
    """Extra UDP clients (``--udp-out``), else None (no column)."""


def _optional(rows: Sequence[VehicleEndpoints]) -> list[tuple[str, str, str]]:
    """(attribute, wide header, stacked label) of the optional entries any row has."""
    fields = (
        ("models", "link models (onboard / GCS)", "link models"),
        ("serial", "serial (uart)", "serial (uart)"),
        ("udp_out", "UDP out", "UDP out"),
    )
    return [f for f in fields if any(getattr(r, f[0]) is not None for r in rows)]


def wide_table(title: str, rows: Sequence[VehicleEndpoints]) -> Table:
    """One line per vehicle, one column per entry (needs a wide terminal)."""
    optional = _optional(rows)
    table = Table(title=title, caption=CAPTION)
    headers = ("sysid", "airframe", "onboard link", "MAVSDK connects with", "GCS link")
    for header in (*headers, *(f[1] for f in optional), "home lat, lon, alt"):
        table.add_column(header, no_wrap=True)
    for r in rows:
        extra = (getattr(r, f[0]) or "-" for f in optional)
        table.add_row(str(r.sysid), r.airframe, r.onboard, r.mavsdk, r.gcs, *extra, r.home)
    return table


def stacked_table(title: str, rows: Sequence[VehicleEndpoints]) -> Table:
    """A few labelled lines per vehicle: fits 80 columns with every address whole."""
    optional = _optional(rows)
    table = Table(title=title, caption=CAPTION)
    table.add_column("vehicle", overflow="fold")
    table.add_column("endpoint", no_wrap=True)
    table.add_column("address / position", no_wrap=True, overflow="fold")  # fold, never "…"
    for r in rows:
        lines = [
            ("MAVSDK URL", r.mavsdk),
            ("onboard link", r.onboard),
            ("GCS link", r.gcs),
            *((f[2], getattr(r, f[0]) or "-") for f in optional),
            ("home", r.home),
        ]
        for k, (label, value) in enumerate(lines):
            vehicle = f"{r.sysid} {r.airframe}" if k == 0 else ""
            table.add_row(vehicle, label, value, end_section=k == len(lines) - 1)
    return table


def endpoint_table(console: Console, title: str, rows: Sequence[VehicleEndpoints]) -> Table:
    """:func:`wide_table` if it fits ``console``'s width, else :func:`stacked_table`."""
    wide = wide_table(title, rows)
    unbounded = console.options.update_width(1_000_000)  # its natural width, not the console's
    if console.measure(wide, options=unbounded).maximum <= console.width:
        return wide
    return stacked_table(title, rows)
