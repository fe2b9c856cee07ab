"""``swarmsitl up``'s start-up table keeps every URL and port whole in an 80-column terminal."""

import pytest
from rich.console import Console

from harness.run.endpoint_table import VehicleEndpoints, endpoint_table
from harness.sim.simulation import PortPlan

PORTS = PortPlan()


def _rows(n, extras=False):
    """Rows as ``up`` formats them for the default port plan."""
    p = PORTS
    return [
        VehicleEndpoints(
            sysid=i + 1,
            airframe="typhoon_h480" if i == 0 else "x500",
            onboard=f"{p.bind_addr}:{p.listen_port(i)} -> {p.peer_addr}:{p.sdk_port(i)}",
            mavsdk=f"udpin://0.0.0.0:{p.sdk_port(i)}",
            gcs=f"{p.bind_addr}:{p.gcs_listen_base + i} -> {p.peer_addr}:{p.gcs_port}",
            home=f"47.39774{i}, 8.545594, 488.0",
            models="uart 921600 Bd 8N1 / sik 57600 Bd 8N1" if extras else None,
            serial=f"RUN/vehicle{i + 1}.serial" if extras else None,
            udp_out=f"{p.peer_addr}:{p.sdk_base + 60 + i}" if extras else None,
        )
        for i in range(n)
    ]


def _render(rows, width):
    console = Console(width=width, record=True)
    console.print(endpoint_table(console, "swarmsitl: a long title naming the run dir", rows))
    return console.export_text()


@pytest.mark.parametrize("extras", [False, True], ids=["plain", "every-option"])
def test_every_url_and_port_is_whole_at_80_columns(extras):
    rows = _rows(3, extras)
    text = _render(rows, 80)
    assert "…" not in text
    assert max(len(line) for line in text.splitlines()) <= 80
    for r in rows:
        cells = [r.mavsdk, r.onboard, r.gcs, r.home, r.airframe]
        cells += [r.models, r.serial, r.udp_out] if extras else []
        for cell in cells:
            assert cell in text, cell


def test_a_wide_terminal_keeps_one_line_per_vehicle():
    rows = _rows(3)
    lines = _render(rows, 200).splitlines()
    for r in rows:
        (line,) = [line for line in lines if r.mavsdk in line]
        assert r.onboard in line and r.gcs in line and r.home in line
