"""Energy accounting per node, per component and per task (seed 000, Table I).

Seed 000 (Ramos et al. 2025, ARCog-NET, Table I) gives one power per component: embedded computer
27 W, UAV propulsion 120 W, radios 1 W, mobile communication module + antenna 100 W, cloud 65 W;
its energies are "power x time" per component and link. This module keeps that ledger for the
nodes of an edge-fog-cloud system in simulation time. Pure: no I/O, no clock.

Over a report window ``[t0, t1]`` of length ``T = t1 - t0`` the energy of a node is, in J:

- constant loads (always on while the node exists): ``E_computer = P_computer * T``,
  ``E_cloud = P_cloud * T``;
- airtime-scaled radios, one radio per link kind ``k`` the node carries, with ``a_k`` the seconds it
  transmitted in the window (from the link models' ``airtime_s_by_node()``):
  ``E_k = P_tx * a_k + P_idle * (T - a_k)``; ``P_tx`` is ``radio_w`` (1 W) for ``wifi`` and ``sik``
  and ``mobile_comm_w`` (100 W, the LTE module + antenna) for ``lte``; ``uart`` and ``wired`` cost
  nothing here (their transceivers are part of the computer's and the autopilot's draw);
- propulsion: ``E_prop = integral P(t) dt`` of the flight model's rotor power samples with the
  trapezoid rule (piecewise-linear between samples, interpolated at the window's ends, zero outside
  the sampled span); without samples the paper's constant ``propulsion_w`` (120 W) times the time
  the node is flying (its flight windows, by default the whole report window).

Per task instance ``(node_id, name, start_s, end_s)`` of duration ``d`` the node's energy over the
interval is ``(P_computer + P_cloud) * d + integral_start^end P(t) dt`` plus, per radio, the power
at the node's mean airtime share over the window ``(P_tx * a_k / T + P_idle * (1 - a_k / T)) * d``.
Tasks that tile the report window therefore sum to the node's total. Seed 000 reports J/task: the
report gives the sum per task name and the mean per instance.

Idle radio draw: 0 W by default (``radio_idle_w``, ``mobile_comm_idle_w``): Table I gives a single
figure per radio and seed 000 counts energy as power x active time per link, so a radio costs only
while it transmits; set an idle draw to count a receiving or listening radio.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

COMPONENTS: tuple[str, ...] = ("embedded_computer", "radio", "mobile_comm", "cloud", "propulsion")
"""Component names of the ledger, in report order."""

ROLE_COMPONENTS: dict[str, frozenset[str]] = {
    "edge": frozenset({"embedded_computer", "radio", "mobile_comm", "propulsion"}),
    "fog": frozenset({"embedded_computer", "radio", "mobile_comm", "propulsion"}),
    "cloud": frozenset({"cloud"}),
    "ground": frozenset({"embedded_computer", "radio"}),
}
"""The components each role carries: edge UAV (companion computer, WiFi radio, the 4G module
every UAV carries (seed 000, Table II: "4G telemetry"), rotors), fog UAV (the same; the 4G module
is its uplink to the cloud), cloud (the server only), ground station (computer + radio). The 4G
module of an edge costs nothing unless the edge transmits on LTE (airtime-scaled, 0 W idle)."""

ROLE_RADIOS: dict[str, tuple[str, ...]] = {
    "edge": ("wifi", "lte"),
    "fog": ("wifi", "lte"),
    "cloud": (),
    "ground": ("sik",),
}
"""Link kinds whose radio each role carries even when it never transmits (matters only for an
idle draw); kinds with recorded airtime are added."""

LINK_KIND_COMPONENT: dict[str, str | None] = {
    "wifi": "radio",
    "sik": "radio",
    "lte": "mobile_comm",
    "uart": None,
    "wired": None,
}
"""The component that pays for transmitting on each link kind (None: not counted)."""


@dataclass(frozen=True)
class NodePowerProfile:
    """Power of each component of a node, W (defaults: seed 000, Table I)."""

    embedded_computer_w: float = 27.0
    """Companion computer (Raspberry Pi 5), constant while the node runs (Table I: 27 W)."""
    radio_w: float = 1.0
    """One radio (WiFi, SiK) while transmitting, scaled by airtime (Table I "Radios": 1 W)."""
    radio_idle_w: float = 0.0
    """One radio while not transmitting; 0 W keeps seed 000's power x active-time accounting."""
    mobile_comm_w: float = 100.0
    """Mobile communication (LTE) module + antenna while transmitting on ``lte``, scaled by
    airtime (Table I: 100 W)."""
    mobile_comm_idle_w: float = 0.0
    """LTE module + antenna while not transmitting; 0 W as for the radios."""
    cloud_w: float = 65.0
    """Cloud server, constant (Table I: 65 W)."""
    propulsion_w: float = 120.0
    """Rotors while flying when no flight-model power was recorded (Table I "UAV (propulsion)":
    120 W)."""

    def __post_init__(self) -> None:
        for name in (
            "embedded_computer_w",
            "radio_w",
            "radio_idle_w",
            "mobile_comm_w",
            "mobile_comm_idle_w",
            "cloud_w",
            "propulsion_w",
        ):
            value = getattr(self, name)
            if not (isinstance(value, numbers.Real) and math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be a finite power >= 0 W, got {value!r}")

    def tx_idle_w(self, component: str) -> tuple[float, float]:
        """(transmitting, idle) power of an airtime-scaled component, W."""
        if component == "mobile_comm":
            return self.mobile_comm_w, self.mobile_comm_idle_w
        return self.radio_w, self.radio_idle_w


@dataclass(frozen=True)
class TaskInterval:
    """One task instance executed by one node over ``[start_s, end_s]`` (simulation time, s)."""

    node_id: str
    """Node that executes the task."""
    name: str
    """Task name; instances of one name are summed and averaged in the report."""
    start_s: float
    """Start of the task, s."""
    end_s: float
    """End of the task, s (>= start_s)."""

    def __post_init__(self) -> None:
        for name in ("start_s", "end_s"):
            value = getattr(self, name)
            if not (isinstance(value, numbers.Real) and math.isfinite(value)):
                raise ValueError(f"{name} must be a finite time in s, got {value!r}")
        if self.end_s < self.start_s:
            raise ValueError(
                f"end_s ({self.end_s}) must be >= start_s ({self.start_s}) for task "
                f"{self.name!r} of node {self.node_id!r}"
            )


@dataclass
class _Node:
    """Ledger state of one node."""

    role: str
    profile: NodePowerProfile
    times_s: list[float] = field(default_factory=list)
    powers_w: list[float] = field(default_factory=list)
    flight_windows_s: list[tuple[float, float]] = field(default_factory=list)
    airtime_s: dict[str, float] = field(default_factory=dict)


class EnergyLedger:
    """Energy per node, component and task of an edge-fog-cloud system (see the module doc)."""

    def __init__(self) -> None:
        self._nodes: dict[str, _Node] = {}

    @property
    def node_ids(self) -> tuple[str, ...]:
        """The nodes added so far, in order."""
        return tuple(self._nodes)

    def add_node(self, node_id: str, role: str, profile: NodePowerProfile | None = None) -> None:
        """Add a node of a role (edge, fog, cloud, ground); Table I powers by default."""
        if role not in ROLE_COMPONENTS:
            raise ValueError(
                f"role {role!r} of node {node_id!r} is unknown; "
                f"available: {', '.join(sorted(ROLE_COMPONENTS))}"
            )
        if node_id in self._nodes:
            raise ValueError(f"node_id {node_id!r} was already added")
        if profile is not None and not isinstance(profile, NodePowerProfile):
            raise ValueError(f"profile of node {node_id!r} must be a NodePowerProfile")
        self._nodes[node_id] = _Node(role, profile or NodePowerProfile())

    def record_propulsion(self, node_id: str, t_s: float, power_w: float) -> None:
        """Add a sample of the rotors' electrical power at simulation time ``t_s``.

        Pass the rotor power only (``FleetPower.rotor_power_w[i]``): ``electrical_power_w`` adds
        the payload loads, whose seed-000 presets hold the embedded computer this ledger already
        counts. Times must increase.
        """
        node = self._flying_node(node_id)
        if not math.isfinite(t_s):
            raise ValueError(f"t_s must be a finite time in s, got {t_s!r}")
        if not (math.isfinite(power_w) and power_w >= 0.0):
            raise ValueError(
                f"power_w of node {node_id!r} must be finite and >= 0, got {power_w!r}"
            )
        if node.times_s and t_s <= node.times_s[-1]:
            raise ValueError(
                f"t_s ({t_s}) of node {node_id!r} must follow the last sample ({node.times_s[-1]})"
            )
        node.times_s.append(float(t_s))
        node.powers_w.append(float(power_w))

    def record_propulsion_fleet(
        self, node_ids: Sequence[str], t_s: float, power_w: np.ndarray
    ) -> None:
        """Add one sample per vehicle: ``power_w[i]`` (W) is node ``node_ids[i]``'s rotor power."""
        powers = np.asarray(power_w, dtype=float)
        if powers.shape != (len(node_ids),):
            raise ValueError(
                f"power_w has shape {powers.shape}, expected ({len(node_ids)},) for the node_ids"
            )
        for node_id, watts in zip(node_ids, powers.tolist(), strict=True):
            self.record_propulsion(node_id, t_s, watts)

    def add_flight_window(self, node_id: str, start_s: float, end_s: float) -> None:
        """Mark the node flying over ``[start_s, end_s]`` for the constant-power fallback.

        Without any window a flying role counts as flying over the whole report window. Ignored
        once flight-model samples exist.
        """
        node = self._flying_node(node_id)
        window = TaskInterval(node_id, "flight", start_s, end_s)
        node.flight_windows_s.append((float(window.start_s), float(window.end_s)))

    def set_airtime(self, node_id: str, airtime_s: Mapping[str, float]) -> None:
        """Set the seconds the node transmitted per link kind in the report window (replaces)."""
        node = self._node(node_id)
        checked: dict[str, float] = {}
        for kind, seconds in airtime_s.items():
            # A kind the ledger does not know (a custom preset's ``kind``) is kept and costs
            # nothing: name it wifi, sik or lte in the link file to have it counted.
            if not (math.isfinite(seconds) and seconds >= 0.0):
                raise ValueError(
                    f"airtime_s[{kind!r}] of node {node_id!r} must be finite and >= 0, "
                    f"got {seconds!r}"
                )
            # A kind whose component the role does not carry is kept but costs nothing: the
            # cloud's LTE downlink is sent by the operator's base station, not by the server.
            checked[kind] = float(seconds)
        node.airtime_s = checked

    def set_airtimes(self, airtime_s_by_node: Mapping[str, Mapping[str, float]]) -> None:
        """``set_airtime`` for each node of a link model's ``airtime_s_by_node()``."""
        for node_id, airtime in airtime_s_by_node.items():
            self.set_airtime(node_id, airtime)

    def report(
        self,
        t0_s: float,
        t1_s: float,
        tasks: Iterable[TaskInterval | tuple[str, str, float, float]] | None = None,
    ) -> dict:
        """Energy (J) and mean power (W) per node and component over ``[t0_s, t1_s]``, and per task.

        Returns plain dicts, lists, str and float (JSON-serialisable)::

            {"t0_s", "t1_s", "duration_s", "total_j", "components_j": {component: J},
             "nodes": {node_id: {"role", "total_j", "mean_power_w", "components_j",
                                 "mean_power_by_component_w", "airtime_s",
                                 "propulsion_source", "propulsion_time_s"}},
             "tasks": {name: {"instances", "duration_s", "total_j", "mean_j_per_task",
                              "components_j"}},
             "task_instances": [{"node_id", "name", "start_s", "end_s", "energy_j",
                                 "components_j"}]}

        ``propulsion_source`` is ``"flight_model"`` (samples integrated), ``"fallback"``
        (``propulsion_w`` while flying) or ``"none"`` (a role without rotors);
        ``propulsion_time_s`` is the time covered by the samples or flown at the fallback power.
        """
        for name, value in (("t0_s", t0_s), ("t1_s", t1_s)):
            if not (isinstance(value, numbers.Real) and math.isfinite(value)):
                raise ValueError(f"{name} must be a finite time in s, got {value!r}")
        if t1_s < t0_s:
            raise ValueError(f"t1_s ({t1_s}) must be >= t0_s ({t0_s})")
        t0, t1 = float(t0_s), float(t1_s)
        duration = t1 - t0
        instances = [self._task(task, t0, t1) for task in (tasks or ())]

        nodes_out: dict[str, dict] = {}
        totals = dict.fromkeys(COMPONENTS, 0.0)
        for node_id, node in self._nodes.items():
            radio_w = self._radio_power_w(node_id, node, duration)
            components = self._interval_j(node, t0, t1, radio_w)
            prop_source, prop_time = self._propulsion_source(node, t0, t1)
            total = sum(components.values())
            nodes_out[node_id] = {
                "role": node.role,
                "total_j": total,
                "mean_power_w": total / duration if duration > 0 else 0.0,
                "components_j": components,
                "mean_power_by_component_w": {
                    c: (e / duration if duration > 0 else 0.0) for c, e in components.items()
                },
                "airtime_s": dict(node.airtime_s),
                "propulsion_source": prop_source,
                "propulsion_time_s": prop_time,
            }
            for c, e in components.items():
                totals[c] += e

        tasks_out: dict[str, dict] = {}
        instances_out: list[dict] = []
        for task in instances:
            node = self._nodes[task.node_id]
            radio_w = self._radio_power_w(task.node_id, node, duration)
            components = self._interval_j(node, task.start_s, task.end_s, radio_w)
            energy = sum(components.values())
            instances_out.append(
                {
                    "node_id": task.node_id,
                    "name": task.name,
                    "start_s": float(task.start_s),
                    "end_s": float(task.end_s),
                    "energy_j": energy,
                    "components_j": components,
                }
            )
            entry = tasks_out.setdefault(
                task.name,
                {
                    "instances": 0,
                    "duration_s": 0.0,
                    "total_j": 0.0,
                    "components_j": dict.fromkeys(COMPONENTS, 0.0),
                },
            )
            entry["instances"] += 1
            entry["duration_s"] += float(task.end_s - task.start_s)
            entry["total_j"] += energy
            for c, e in components.items():
                entry["components_j"][c] += e
        for entry in tasks_out.values():
            entry["mean_j_per_task"] = entry["total_j"] / entry["instances"]

        return {
            "t0_s": t0,
            "t1_s": t1,
            "duration_s": duration,
            "total_j": sum(totals.values()),
            "components_j": totals,
            "nodes": nodes_out,
            "tasks": tasks_out,
            "task_instances": instances_out,
        }

    # -- internals -------------------------------------------------------------------------

    def _node(self, node_id: str) -> _Node:
        try:
            return self._nodes[node_id]
        except KeyError:
            raise ValueError(f"node_id {node_id!r} was not added") from None

    def _flying_node(self, node_id: str) -> _Node:
        node = self._node(node_id)
        if "propulsion" not in ROLE_COMPONENTS[node.role]:
            raise ValueError(f"node_id {node_id!r}: a {node.role} node has no propulsion")
        return node

    def _task(
        self, task: TaskInterval | tuple[str, str, float, float], t0: float, t1: float
    ) -> TaskInterval:
        if not isinstance(task, TaskInterval):
            task = TaskInterval(*task)
        self._node(task.node_id)
        if task.start_s < t0 or task.end_s > t1:
            raise ValueError(
                f"task {task.name!r} of node {task.node_id!r}: start_s..end_s "
                f"({task.start_s}..{task.end_s}) must lie in the report window {t0}..{t1}"
            )
        return task

    def _radio_power_w(self, node_id: str, node: _Node, duration: float) -> dict[str, float]:
        """Mean power of the airtime-scaled components over the window, W, per component."""
        power = {"radio": 0.0, "mobile_comm": 0.0}
        kinds = dict.fromkeys(ROLE_RADIOS[node.role], 0.0) | node.airtime_s
        for kind, airtime in kinds.items():
            component = LINK_KIND_COMPONENT.get(kind)
            if component is None or component not in ROLE_COMPONENTS[node.role]:
                continue
            # The link models give each peer its own transmit queue, so a node's airtime summed
            # over its peers may exceed the window under heavy load: the radio is then busy
            # all the time (share 1).
            share = min(1.0, airtime / duration) if duration > 0 else 0.0
            tx_w, idle_w = node.profile.tx_idle_w(component)
            power[component] += tx_w * share + idle_w * (1.0 - share)
        return power

    def _interval_j(
        self, node: _Node, start: float, end: float, radio_w: Mapping[str, float]
    ) -> dict[str, float]:
        """Energy per component over ``[start, end]``, J."""
        has = ROLE_COMPONENTS[node.role]
        d = end - start
        profile = node.profile
        return {
            "embedded_computer": profile.embedded_computer_w * d
            if "embedded_computer" in has
            else 0.0,
            "radio": radio_w["radio"] * d,
            "mobile_comm": radio_w["mobile_comm"] * d,
            "cloud": profile.cloud_w * d if "cloud" in has else 0.0,
            "propulsion": self._propulsion_j(node, start, end) if "propulsion" in has else 0.0,
        }

    @staticmethod
    def _propulsion_j(node: _Node, start: float, end: float) -> float:
        """Rotor energy over ``[start, end]``: trapezoid over the samples, else the fallback."""
        if node.times_s:
            return _trapezoid_j(np.array(node.times_s), np.array(node.powers_w), start, end)
        windows = node.flight_windows_s or [(start, end)]
        return node.profile.propulsion_w * _overlap_s(windows, start, end)

    @staticmethod
    def _propulsion_source(node: _Node, t0: float, t1: float) -> tuple[str, float]:
        if "propulsion" not in ROLE_COMPONENTS[node.role]:
            return "none", 0.0
        if node.times_s:
            return "flight_model", max(0.0, min(t1, node.times_s[-1]) - max(t0, node.times_s[0]))
        return "fallback", _overlap_s(node.flight_windows_s or [(t0, t1)], t0, t1)


def _overlap_s(windows: Sequence[tuple[float, float]], start: float, end: float) -> float:
    """Time of ``[start, end]`` covered by the union of the windows, s."""
    covered = 0.0
    cursor = start
    for lo, hi in sorted(windows):
        lo, hi = max(lo, cursor), min(hi, end)
        if hi > lo:
            covered += hi - lo
            cursor = hi
    return covered


def _trapezoid_j(times_s: np.ndarray, powers_w: np.ndarray, start: float, end: float) -> float:
    """Integral of the piecewise-linear power over ``[start, end]`` within the samples' span, J."""
    lo, hi = max(start, times_s[0]), min(end, times_s[-1])
    if hi <= lo:
        return 0.0
    inner = (times_s > lo) & (times_s < hi)
    t = np.concatenate(([lo], times_s[inner], [hi]))
    p = np.interp(t, times_s, powers_w)
    return float(np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(t)))
