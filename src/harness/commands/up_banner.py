"""What ``swarmsitl up`` prints: where to connect at the start, the link loads at the end."""

from __future__ import annotations

from pathlib import Path

from rich.markup import escape

from autopilot_emu.mavlink.transport import SERIAL_BAUD
from harness.commands.autopilot import (
    print_external_table,
)
from harness.commands.params import ParamsLoad, print_params_load
from harness.run.endpoint_table import VehicleEndpoints, endpoint_table
from harness.run.launch import console
from harness.sim.link_models import NO_LINK, describe
from harness.sim.simulation import Simulation, SimulationConfig
from harness.sim.world_setup import WorldSetup
from sitl.sensors.camera import RENDER_S_PER_PIXEL


def print_world(
    setup: WorldSetup, path: Path | None, cfg: SimulationConfig, sim: Simulation
) -> None:
    """Tell what the world brought: scene, launch area, wind, and the bridges to start."""
    scene = setup.scene
    wind = cfg.wind
    wind_text = (
        "calm"
        if wind is None
        else f"{wind.speed_m_s:g} m/s from {wind.from_deg:.0f} deg, turbulence W20 "
        f"{wind.turbulence_w20_m_s:.1f} m/s, gusts {wind.gust_peak_m_s:g} m/s"
    )
    console.print(
        f"world {path} ({scene.kind}, seed {scene.seed}): {len(scene.solids)} solids, "
        f"{len(scene.targets)} targets; launch area {setup.launch_area}; wind {wind_text}",
        markup=False,
        highlight=False,
    )
    if setup.bridge:
        ports = cfg.ports
        console.print(
            "GPS-denied world: no GNSS fix; each vehicle flies on motion capture through its "
            f"bridge (EKF2_EV_CTRL {setup.params.get('EKF2_EV_CTRL', 0):g}):",
            markup=False,
        )
        for i in range(cfg.n_vehicles):
            listen = f"{ports.peer_addr}:{cfg.mocap_port + i}"
            onboard = ports.listen_port(i)
            console.print(
                f"  python -m companion.scripts.mocap_bridge --vehicle {i} --listen {listen} "
                f"--mavlink udpout:{ports.bind_addr}:{onboard}",
                markup=False,
                highlight=False,
                soft_wrap=True,
            )


def print_link_loads(sim: Simulation) -> None:
    """One line per modelled MAVLink link: frames, drops by reason, load."""
    elapsed = max(sim.time_s, 1e-9)
    for (i, path), shaper in sorted(sim.shapers.items()):
        stats = shaper.stats
        parts = []
        for label, d in (("to vehicle", stats.to_vehicle), ("from vehicle", stats.from_vehicle)):
            drops = ", ".join(f"{k} {v}" for k, v in sorted(d.dropped.items())) or "none"
            parts.append(
                f"{label}: {d.frames} frames, {d.bytes / elapsed:.0f} B/s, "
                f"load {100 * d.airtime_s / elapsed:.0f} %, dropped {drops}"
            )
        console.print(f"{path} link of vehicle {i + 1} ({stats.kind}): " + "; ".join(parts))


def print_banner(
    sim: Simulation,
    cfg: SimulationConfig,
    pace: str,
    run_dir: Path,
    signing_key_file: Path | None,
    setup: WorldSetup | None,
    world_file: Path | None,
    params_load: ParamsLoad | None,
    camera: bool,
    speed: float,
) -> None:
    """What ``up`` started and where to connect: links, signing, mocap, serial ports, cameras."""
    ports, bind = cfg.ports, cfg.ports.bind_addr
    if sim.hil is not None:
        print_external_table(sim, run_dir, pace)
    else:
        title = f"swarmsitl: {cfg.n_vehicles} vehicle(s), {pace}, run dir {run_dir}"
        modelled = cfg.onboard_link != NO_LINK or (cfg.gcs_link != NO_LINK and ports.gcs_port)
        rows = []
        for i in range(cfg.n_vehicles):
            lat, lon, alt = sim.world.home_geodetic(i)
            gcs = "off"
            if ports.gcs_port:
                gcs = f"{bind}:{ports.gcs_listen_port(i)} -> {ports.peer_addr}:{ports.gcs_port}"
            models = (
                f"{describe(cfg.onboard_link, cfg.links)} / "
                f"{describe(cfg.gcs_link, cfg.links) if ports.gcs_port else '-'}"
            )
            rows.append(
                VehicleEndpoints(
                    sysid=i + 1,
                    airframe=sim.world.airframes[i].name,
                    onboard=f"{bind}:{ports.listen_port(i)} -> "
                    f"{ports.peer_addr}:{ports.sdk_port(i)}",
                    mavsdk=f"udpin://0.0.0.0:{ports.sdk_port(i)}",
                    gcs=gcs,
                    home=f"{lat:.6f}, {lon:.6f}, {alt:.1f}",
                    models=models if modelled else None,
                    serial=f"RUN/{Path(str(sim.serial_ports[i])).name}" if cfg.serial else None,
                    udp_out=", ".join(d.describe(i) for d in cfg.udp_outs)
                    if cfg.udp_outs
                    else None,
                )
            )
        console.print(endpoint_table(console, title, rows))  # fits the terminal, URLs whole
    if cfg.signing_key is not None:
        console.print(
            "MAVLink 2 signing: every link signs its frames and accepts only frames signed with "
            f"the key of {escape(str(signing_key_file)) if signing_key_file else 'the passphrase'}"
            " (unsigned RADIO_STATUS, ADSB_VEHICLE, COLLISION excepted, as PX4); clients must "
            "sign with it (pymavlink: setup_signing; MAVSDK cannot sign, its commands are dropped)"
        )
    if sim.mocap is not None:
        console.print(
            f"motion capture: {sim.world.config.mocap_hz:g} Hz, vehicle i's poses to udp "
            f"{ports.peer_addr}:{cfg.mocap_port}+i "
            "(bridge: python -m companion.scripts.mocap_bridge)"
        )
    for i, path in enumerate(sim.serial_ports):
        if path is not None:
            console.print(
                f"serial port of vehicle {i + 1}: serial://{path}:{SERIAL_BAUD} (pymavlink: "
                f"mavlink_connection({str(path)!r}, baud={SERIAL_BAUD}))",
                soft_wrap=True,
            )
    for k, dest in enumerate(cfg.udp_outs, start=1):
        where = f"{dest.host}:{dest.port}" + ("+i" if dest.per_vehicle else " (every vehicle)")
        console.print(
            f"UDP output {k}: vehicle i's extra link (normal profile) sends to {where}; "
            f"tlogs vehicleN-udp{k}.tlog",
            soft_wrap=True,
        )
    if setup is not None:
        print_world(setup, world_file, cfg, sim)
    print_params_load(params_load)
    for i, (uri, spec) in enumerate(zip(sim.video_uris, sim.world.camera_specs, strict=True)):
        if uri is not None and spec is not None:
            console.print(
                f"camera of vehicle {i + 1}: {uri}  ({spec.width_px}x{spec.height_px}, "
                f"{spec.rate_hz:g} Hz, hfov {spec.hfov_deg:g} deg, pitch {spec.pitch_deg:g} deg)"
            )
    for i, manager in enumerate(sim.camera_managers):
        if manager is not None:
            console.print(
                f"MAVLink camera of vehicle {i + 1}: system {i + 1} component 100, "
                f"udp {manager.local_address[0]}:{manager.local_address[1]} <-> payload link "
                f"{bind}:{ports.payload_listen_port(i)} (forwarded to the links above)"
            )
    if camera and not any(sim.video_uris):
        console.print("cameras: none of these airframes has one (no streams)")
    render_load = (
        speed
        * RENDER_S_PER_PIXEL
        * sum(s.rate_hz * s.width_px * s.height_px for s in sim.world.camera_specs if s is not None)
    )
    if render_load > 0.5:
        console.print(
            f"[yellow]note:[/yellow] rendering the cameras takes about {render_load:.1f} CPU "
            f"seconds per wall second at --speed {speed:g}; lighten it with --camera-hz, "
            "--camera-size, or --no-camera"
        )
