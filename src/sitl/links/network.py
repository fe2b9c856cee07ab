"""Nodes with roles joined by link classes: which link a datagram crosses, and what it cost.

``LinkNetwork`` holds the nodes (id, role, optional ENU position) and one :class:`LinkChannel`
per directed pair, created on first use with its own generator seeded from (seed, src, dst) by
``zlib.crc32`` (stable across runs and Python versions): the same seed and the same traffic on a
pair give the same drops and delays whatever the other pairs carry. The link class comes from the
two roles (``edge-fog``); the direction from the layers (edge < fog < cloud < ground: toward the
higher layer is "up"; between nodes of one layer the "up" parameters serve both directions).

Range (WiFi, SiK) uses the distance between the two nodes' positions; coverage (LTE) checks each
node that has a position. A node without a position is at distance 0 and always covered.

``mavlink_channels`` gives the two directions of a point-to-point link (companion <-> autopilot
over the UART, ground station <-> vehicle over SiK) outside any network.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sitl.links.channel import ChannelStats, Drop, LinkChannel
from sitl.links.config import ROLE_RANK, LinkPreset, LinksConfig, canonical_class


def _stable_rng(seed: int, label: str) -> np.random.Generator:
    """A generator seeded from (seed, label) through crc32 (never Python's salted ``hash``)."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), zlib.crc32(label.encode())]))


@dataclass(slots=True)
class _Route:
    """What the network knows of one directed pair."""

    channel: LinkChannel | None
    """None: no link joins the two roles."""
    class_name: str
    direction: str
    """``src_role->dst_role``."""
    preset: LinkPreset | None
    geometric: bool
    """Whether range or coverage needs the positions."""


class LinkNetwork:
    """Nodes, their roles and positions, and the links between them.

    Args:
        config: presets and link classes.
        seed: the run's seed (each directed pair derives its own generator from it).
    """

    def __init__(self, config: LinksConfig, seed: int) -> None:
        self.config = config
        self.seed = int(seed)
        self._roles: dict[str, str] = {}
        self._positions: dict[str, tuple[float, float, float]] = {}
        self._routes: dict[tuple[str, str], _Route] = {}
        self._no_link: dict[tuple[str, str], ChannelStats] = {}

    # -- nodes -------------------------------------------------------------------------------

    def add_node(self, node_id: str, role: str) -> None:
        """Add a node (``role``: edge, fog, cloud or ground).

        Raises:
            ValueError: unknown role, or the id is taken by a node of another role.
        """
        if role not in ROLE_RANK:
            known = ", ".join(ROLE_RANK)
            raise ValueError(f"node {node_id!r}: unknown role {role!r} (known: {known})")
        if self._roles.get(node_id, role) != role:
            raise ValueError(f"node {node_id!r} already has the role {self._roles[node_id]!r}")
        self._roles[node_id] = role

    @property
    def nodes(self) -> dict[str, str]:
        """Node id -> role."""
        return dict(self._roles)

    def set_position(self, node_id: str, enu_m: Sequence[float]) -> None:
        """Place a node (east, north, up in m) for range and coverage."""
        self._role(node_id)
        east, north, up = (float(v) for v in enu_m)
        if not all(math.isfinite(v) for v in (east, north, up)):
            raise ValueError(f"position of {node_id!r} must be finite, got {tuple(enu_m)!r}")
        self._positions[node_id] = (east, north, up)

    def _role(self, node_id: str) -> str:
        try:
            return self._roles[node_id]
        except KeyError:
            raise ValueError(f"unknown node {node_id!r} (add_node it first)") from None

    # -- datagrams ---------------------------------------------------------------------------

    def _route(self, src: str, dst: str) -> _Route:
        src_role, dst_role = self._role(src), self._role(dst)
        if src == dst:
            raise ValueError(f"node {src!r} sends to itself: no link carries that")
        class_name = canonical_class(src_role, dst_role)
        preset_name = self.config.classes.get(class_name)
        direction = f"{src_role}->{dst_role}"
        if preset_name is None:
            return _Route(None, class_name, direction, None, False)
        preset = self.config.presets[preset_name]
        params = preset.down if ROLE_RANK[dst_role] < ROLE_RANK[src_role] else preset.up
        channel = LinkChannel(params, _stable_rng(self.seed, f"{src}\x00{dst}"))
        geometric = params.range_m != math.inf or bool(preset.coverage)
        return _Route(channel, class_name, direction, preset, geometric)

    def submit(
        self, now_s: float, src: str, dst: str, payload_bytes: int
    ) -> tuple[float | None, Drop | None]:
        """Send a datagram of ``payload_bytes`` from ``src`` to ``dst`` at ``now_s``.

        Returns:
            (arrival time in s, None), or (None, why it was dropped).

        Raises:
            DatagramTooLargeError: larger than the link's ``max_datagram_bytes``.
            ValueError: an unknown node, or ``src == dst``.
        """
        route = self._routes.get((src, dst))
        if route is None:
            route = self._routes[(src, dst)] = self._route(src, dst)
        channel = route.channel
        if channel is None:
            stats = self._no_link.setdefault((src, dst), ChannelStats())
            stats.submitted += 1
            stats.submitted_bytes += payload_bytes
            stats.dropped[Drop.NO_LINK.value] = stats.dropped.get(Drop.NO_LINK.value, 0) + 1
            return None, Drop.NO_LINK
        if not route.geometric:
            return channel.submit(now_s, payload_bytes)
        a = self._positions.get(src)
        b = self._positions.get(dst)
        coverage = route.preset.coverage
        if coverage and not (
            (a is None or route.preset.covers(a[0], a[1]))
            and (b is None or route.preset.covers(b[0], b[1]))
        ):
            return channel.refuse(Drop.COVERAGE, payload_bytes)
        distance = math.dist(a, b) if a is not None and b is not None else 0.0
        return channel.submit(now_s, payload_bytes, distance)

    def channel(self, src: str, dst: str) -> LinkChannel | None:
        """The channel from ``src`` to ``dst`` (created if needed; None when no link joins them)."""
        route = self._routes.get((src, dst))
        if route is None:
            route = self._routes[(src, dst)] = self._route(src, dst)
        return route.channel

    def channel_pair(self, preset_name: str, name: str) -> tuple[LinkChannel, LinkChannel]:
        """(up, down) channels of a point-to-point link outside the node graph.

        Seeded from (seed, ``name``): a stable label such as ``"mavlink/uart/0"``.
        """
        return _channel_pair(self.config.preset(preset_name), self.seed, name)

    # -- records -----------------------------------------------------------------------------

    def records(self, duration_s: float) -> dict:
        """Seed 000's link metrics per link class and per direction over a run of ``duration_s``.

        Returns:
            ``{"duration_s": d, "classes": {class: metrics}, "directions": {"edge->fog":
            metrics}}``; metrics as in docs/links.md (datagrams and bytes submitted and
            delivered, drops by reason, loss_pct, availability_pct, uptime_pct, latency_ms,
            throughput_bps, airtime_s, links).
        """
        if not duration_s > 0:
            raise ValueError(f"duration_s: must be > 0 s, got {duration_s!r}")
        by_class: dict[str, list[tuple[ChannelStats, LinkChannel | None]]] = {}
        by_direction: dict[str, list[tuple[ChannelStats, LinkChannel | None]]] = {}
        for (src, dst), route in self._routes.items():
            stats = route.channel.stats if route.channel is not None else self._no_link[src, dst]
            by_class.setdefault(route.class_name, []).append((stats, route.channel))
            by_direction.setdefault(route.direction, []).append((stats, route.channel))
        return {
            "duration_s": float(duration_s),
            "classes": {
                name: {"preset": self.config.classes.get(name), **_metrics(items, duration_s)}
                for name, items in sorted(by_class.items())
            },
            "directions": {
                name: _metrics(items, duration_s) for name, items in sorted(by_direction.items())
            },
        }

    def airtime_s_by_node(self) -> dict[str, dict[str, float]]:
        """Seconds each node spent transmitting, by link kind (``{"uav1": {"wifi": 0.8}}``)."""
        out: dict[str, dict[str, float]] = {}
        for (src, _dst), route in self._routes.items():
            if route.channel is None:
                continue
            kinds = out.setdefault(src, {})
            kind = route.channel.params.kind
            kinds[kind] = kinds.get(kind, 0.0) + route.channel.stats.airtime_s
        return out


def _metrics(items: list[tuple[ChannelStats, LinkChannel | None]], duration_s: float) -> dict:
    """The metrics of a group of directed links (see :meth:`LinkNetwork.records`)."""
    submitted = sum(s.submitted for s, _ in items)
    delivered = sum(s.delivered for s, _ in items)
    drops: dict[str, int] = {}
    for s, _ in items:
        for reason, n in s.dropped.items():
            drops[reason] = drops.get(reason, 0) + n
    latencies = np.concatenate([np.frombuffer(s.latencies_s, dtype=float) for s, _ in items])
    if latencies.size:
        p50, p95 = np.percentile(latencies, [50.0, 95.0]) * 1e3
        latency_ms = {
            "mean": float(latencies.mean() * 1e3),
            "p50": float(p50),
            "p95": float(p95),
            "max": float(latencies.max() * 1e3),
        }
    else:
        latency_ms = {"mean": math.nan, "p50": math.nan, "p95": math.nan, "max": math.nan}
    loss_pct = 100.0 * (submitted - delivered) / submitted if submitted else 0.0
    channels = [c for _, c in items if c is not None]
    uptime = (
        100.0 * sum(c.uptime_fraction(duration_s) for c in channels) / len(channels)
        if channels
        else 0.0
    )
    delivered_bytes = sum(s.delivered_bytes for s, _ in items)
    return {
        "links": len(items),
        "datagrams_submitted": submitted,
        "datagrams_delivered": delivered,
        "bytes_submitted": sum(s.submitted_bytes for s, _ in items),
        "bytes_delivered": delivered_bytes,
        "drops": dict(sorted(drops.items())),
        "loss_pct": loss_pct,
        "availability_pct": 100.0 - loss_pct,
        "uptime_pct": uptime,
        "latency_ms": latency_ms,
        "throughput_bps": delivered_bytes * 8.0 / duration_s,
        "airtime_s": sum(s.airtime_s for s, _ in items),
    }


def _channel_pair(preset: LinkPreset, seed: int, name: str) -> tuple[LinkChannel, LinkChannel]:
    up = LinkChannel(preset.up, _stable_rng(seed, f"{name}/up"))
    down = LinkChannel(preset.down, _stable_rng(seed, f"{name}/down"))
    return up, down


def mavlink_channels(
    preset_name: str,
    config: LinksConfig | None,
    seed: int,
    vehicle_index: int,
    path: str = "onboard",
) -> tuple[LinkChannel, LinkChannel]:
    """The two directions of a vehicle's MAVLink link behind a preset (``uart``, ``sik``).

    ``to_vehicle`` carries the companion's or ground station's traffic to the autopilot with the
    preset's ``down`` parameters (the vehicle is the lower layer), ``from_vehicle`` the
    autopilot's with ``up``. Seeded from (seed, preset, vehicle_index, path) by crc32: each
    vehicle's path (``onboard``, ``gcs``) draws its own numbers, even two paths behind one
    preset. ``config`` None: the shipped presets.

    Raises:
        LinkConfigError: unknown preset.
    """
    config = LinksConfig.load() if config is None else config
    preset = config.preset(preset_name)
    from_vehicle, to_vehicle = _channel_pair(
        preset, seed, f"mavlink/{preset_name}/{int(vehicle_index)}/{path}"
    )
    return to_vehicle, from_vehicle
