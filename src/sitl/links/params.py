"""Parameters of one link (one direction of a physical channel), validated at construction.

A link is what a datagram or a byte stream crosses between two nodes: a UART, a WiFi hop, an LTE
bearer, a SiK radio, a wired/cloud path. Its parameters, SI units inside (``_s``, ``_bps``):

- ``rate_bps``: bit rate on the medium after MAC efficiency (goodput), bits per second;
- ``bits_per_byte``: 8 for packet links; 10 for an asynchronous serial line (8N1: start + 8 data +
  stop), which is what makes a 921600-baud UART carry 92160 bytes per second;
- ``overhead_bytes``: bytes every datagram adds on the medium (IPv4 + UDP headers: 28);
- ``queue_bytes``: the transmitter's drop-tail buffer; a datagram that does not fit is dropped;
- ``max_datagram_bytes``: larger datagrams are refused (never truncated);
- ``latency``: propagation + processing delay after the last bit is sent (:class:`LatencyParams`);
- ``loss``: packet loss (:class:`LossParams`), Bernoulli or Gilbert-Elliott bursts;
- ``outages``: up/down events (:class:`OutageParams`);
- ``in_order``: deliveries never overtake each other (serial lines, radios with one queue).

Loading from YAML (:func:`link_params_from_dict`) names the offending field in every error.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from enum import StrEnum
from typing import Any


class LinkConfigError(ValueError):
    """A link parameter is missing, unknown or out of range; the message names the field."""


class Jitter(StrEnum):
    """Family of the random part of the latency (added to ``base_s``)."""

    NONE = "none"
    EXPONENTIAL = "exponential"
    """Exponential with mean ``jitter_s``."""
    LOGNORMAL = "lognormal"
    """Log-normal with median ``jitter_s`` and shape ``sigma`` (right-skewed, as LTE delays)."""
    GAMMA = "gamma"
    """Gamma with mean ``jitter_s`` and shape ``shape``."""


class LossModel(StrEnum):
    """How datagrams are lost on the medium."""

    BERNOULLI = "bernoulli"
    """Each datagram independently with probability ``mean_loss``."""
    GILBERT_ELLIOTT = "gilbert_elliott"
    """Two-state Markov chain per datagram: good (no loss) and bad (loss ``loss_bad``), with the
    transition probabilities that give ``mean_loss`` and bursts of ``mean_burst_packets``."""


def _check(condition: bool, path: str, message: str) -> None:
    if not condition:
        raise LinkConfigError(f"{path}: {message}")


def _finite(value: float) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True)
class LatencyParams:
    """One-way delay after the transmission ends: ``base_s`` + a random jitter."""

    base_s: float = 0.0
    """Fixed part (propagation, processing, scheduling), s."""
    jitter: Jitter = Jitter.NONE
    """Family of the random part."""
    jitter_s: float = 0.0
    """Mean (exponential, gamma) or median (lognormal) of the random part, s."""
    sigma: float = 0.5
    """Log-normal shape (standard deviation of the log)."""
    shape: float = 2.0
    """Gamma shape k."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "jitter", Jitter(self.jitter))
        _check(_finite(self.base_s) and self.base_s >= 0, "latency.base_s", "must be >= 0 s")
        _check(_finite(self.jitter_s) and self.jitter_s >= 0, "latency.jitter_s", "must be >= 0 s")
        _check(_finite(self.sigma) and self.sigma > 0, "latency.sigma", "must be > 0")
        _check(_finite(self.shape) and self.shape > 0, "latency.shape", "must be > 0")

    def distribution(self):  # noqa: ANN201 (scipy's frozen distribution type is private)
        """The delay distribution as a frozen ``scipy.stats`` distribution (for tests, reports)."""
        from scipy import stats

        if self.jitter is Jitter.NONE or self.jitter_s == 0.0:
            # A point mass at base_s (a zero-width uniform has NaN cdf and mean).
            return stats.rv_discrete(values=([0], [1.0]), seed=None)(loc=self.base_s)
        if self.jitter is Jitter.EXPONENTIAL:
            return stats.expon(loc=self.base_s, scale=self.jitter_s)
        if self.jitter is Jitter.LOGNORMAL:
            return stats.lognorm(s=self.sigma, loc=self.base_s, scale=self.jitter_s)
        return stats.gamma(a=self.shape, loc=self.base_s, scale=self.jitter_s / self.shape)

    @property
    def mean_s(self) -> float:
        """Mean one-way delay, s."""
        if self.jitter is Jitter.LOGNORMAL:
            return self.base_s + self.jitter_s * math.exp(self.sigma**2 / 2)
        return self.base_s + (0.0 if self.jitter is Jitter.NONE else self.jitter_s)


@dataclass(frozen=True)
class LossParams:
    """Packet loss on the medium (after transmission: a lost datagram used its airtime)."""

    model: LossModel = LossModel.BERNOULLI
    mean_loss: float = 0.0
    """Long-run fraction of datagrams lost, 0..1."""
    mean_burst_packets: float = 1.0
    """Gilbert-Elliott: mean length of a bad period, datagrams (>= 1)."""
    loss_bad: float = 1.0
    """Gilbert-Elliott: loss probability in the bad state (the good state loses nothing)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "model", LossModel(self.model))
        _check(
            _finite(self.mean_loss) and 0.0 <= self.mean_loss <= 1.0,
            "loss.mean_loss",
            f"must be within 0..1, got {self.mean_loss!r}",
        )
        _check(
            _finite(self.loss_bad) and 0.0 < self.loss_bad <= 1.0,
            "loss.loss_bad",
            f"must be within (0, 1], got {self.loss_bad!r}",
        )
        _check(
            _finite(self.mean_burst_packets) and self.mean_burst_packets >= 1.0,
            "loss.mean_burst_packets",
            f"must be >= 1, got {self.mean_burst_packets!r}",
        )
        if self.model is LossModel.GILBERT_ELLIOTT:
            _check(
                self.mean_loss <= self.loss_bad,
                "loss.mean_loss",
                f"cannot exceed loss_bad ({self.loss_bad}) in the Gilbert-Elliott model",
            )

    def transition_probabilities(self) -> tuple[float, float]:
        """Gilbert-Elliott (p_good_to_bad, p_bad_to_good) per datagram for the mean and burst.

        The bad state's stationary share is ``mean_loss / loss_bad``; its mean stay is
        ``mean_burst_packets`` datagrams, so ``p_bg = 1 / mean_burst_packets`` and
        ``p_gb = pi_bad p_bg / (1 - pi_bad)``.
        """
        p_bg = 1.0 / self.mean_burst_packets
        pi_bad = self.mean_loss / self.loss_bad
        if pi_bad >= 1.0:
            return 1.0, 0.0
        return pi_bad * p_bg / (1.0 - pi_bad), p_bg


@dataclass(frozen=True)
class OutageParams:
    """When the link is down: fixed windows and random failures.

    Random outages follow an alternating renewal process: up periods exponential with mean
    ``mtbf_s``, down periods exponential with mean ``mttr_s`` (0 = no random outages).
    """

    windows_s: tuple[tuple[float, float], ...] = ()
    """(start, end) simulation times the link is down, s."""
    mtbf_s: float = 0.0
    """Mean time between failures, s; 0: never fails at random."""
    mttr_s: float = 0.0
    """Mean time to repair, s."""

    def __post_init__(self) -> None:
        windows = tuple((float(a), float(b)) for a, b in self.windows_s)
        object.__setattr__(self, "windows_s", windows)
        for k, (start, end) in enumerate(windows):
            _check(
                math.isfinite(start) and math.isfinite(end) and 0.0 <= start < end,
                f"outages.windows_s[{k}]",
                f"needs 0 <= start < end, got ({start}, {end})",
            )
        _check(_finite(self.mtbf_s) and self.mtbf_s >= 0, "outages.mtbf_s", "must be >= 0 s")
        _check(_finite(self.mttr_s) and self.mttr_s >= 0, "outages.mttr_s", "must be >= 0 s")
        _check(
            (self.mtbf_s > 0) == (self.mttr_s > 0),
            "outages.mttr_s",
            "give both mtbf_s and mttr_s (random outages) or neither",
        )

    @property
    def expected_uptime(self) -> float:
        """Long-run fraction of time up from the random outages alone."""
        if self.mtbf_s == 0.0:
            return 1.0
        return self.mtbf_s / (self.mtbf_s + self.mttr_s)


@dataclass(frozen=True)
class LinkParams:
    """One direction of one link (see the module docstring for the fields)."""

    kind: str = "wired"
    """What the link is (uart, wifi, lte, sik, wired): documentation and reports."""
    rate_bps: float = 1e9
    bits_per_byte: int = 8
    overhead_bytes: int = 28
    queue_bytes: int = 1_000_000
    max_datagram_bytes: int = 65507
    latency: LatencyParams = field(default_factory=LatencyParams)
    loss: LossParams = field(default_factory=LossParams)
    outages: OutageParams = field(default_factory=OutageParams)
    in_order: bool = False
    range_m: float = math.inf
    """Distance at which half the datagrams are lost to range (WiFi, radios); inf: no limit."""
    range_width_m: float = 1.0
    """Half-width of the range edge: no range loss within ``range_m - range_width_m``, all lost
    beyond ``range_m + range_width_m``, a raised-cosine ramp between (half lost at range_m)."""

    def __post_init__(self) -> None:
        _check(isinstance(self.kind, str) and self.kind != "", "kind", "must be a name")
        _check(
            _finite(self.rate_bps) and self.rate_bps > 0,
            "rate_bps",
            f"must be a number > 0, got {self.rate_bps!r}",
        )
        _check(self.bits_per_byte in (8, 9, 10, 11, 12), "bits_per_byte", "must be 8..12")
        _check(
            isinstance(self.overhead_bytes, int) and self.overhead_bytes >= 0,
            "overhead_bytes",
            "must be an integer >= 0",
        )
        _check(
            isinstance(self.max_datagram_bytes, int) and self.max_datagram_bytes > 0,
            "max_datagram_bytes",
            "must be an integer > 0",
        )
        _check(
            isinstance(self.queue_bytes, int)
            and self.queue_bytes >= self.max_datagram_bytes + self.overhead_bytes,
            "queue_bytes",
            f"must hold one largest datagram ({self.max_datagram_bytes + self.overhead_bytes} B)",
        )
        _check(
            (_finite(self.range_m) and self.range_m > 0) or self.range_m == math.inf,
            "range_m",
            "must be > 0 m (or inf)",
        )
        _check(
            _finite(self.range_width_m) and self.range_width_m > 0, "range_width_m", "must be > 0"
        )

    def wire_bytes(self, payload_bytes: int) -> int:
        """Bytes a datagram of ``payload_bytes`` occupies on the medium."""
        return payload_bytes + self.overhead_bytes

    def transmit_s(self, payload_bytes: int) -> float:
        """Time to put one datagram on the medium, s."""
        return self.wire_bytes(payload_bytes) * self.bits_per_byte / self.rate_bps

    def range_loss(self, distance_m: float) -> float:
        """Probability of losing a datagram to distance alone (raised-cosine edge at ``range_m``).

        Exactly 0 well inside the range, so the loss model's figures hold there unchanged.
        """
        x = (distance_m - self.range_m) / self.range_width_m  # -1 .. 1 across the edge
        if x <= -1.0:
            return 0.0
        if x >= 1.0:
            return 1.0
        return 0.5 * (1.0 + math.sin(0.5 * math.pi * x))


_SECTIONS: dict[str, type] = {
    "latency": LatencyParams,
    "loss": LossParams,
    "outages": OutageParams,
}


def link_params_from_dict(data: Mapping[str, Any], path: str = "link") -> LinkParams:
    """A :class:`LinkParams` from a YAML mapping; errors name the field (``path.loss.mean_loss``).

    Keys other than the fields (such as ``source:`` notes) are refused, except ``sources``, a
    free mapping of citations that the YAML keeps beside the numbers.
    """
    if not isinstance(data, Mapping):
        raise LinkConfigError(f"{path}: must be a mapping, got {type(data).__name__}")
    names = {f.name for f in fields(LinkParams)}
    kwargs: dict[str, Any] = {}
    for key, value in data.items():
        if key == "sources":
            continue
        if key not in names:
            raise LinkConfigError(
                f"{path}.{key}: unknown field (known: {', '.join(sorted(names))})"
            )
        if key in _SECTIONS:
            kwargs[key] = _section_at(_SECTIONS[key], value, f"{path}.{key}")
        elif key == "range_m" and value in ("inf", ".inf", None):
            kwargs[key] = math.inf
        else:
            kwargs[key] = value
    try:
        return LinkParams(**kwargs)
    except LinkConfigError as exc:
        raise LinkConfigError(f"{path}.{exc}") from None
    except (TypeError, ValueError) as exc:
        raise LinkConfigError(f"{path}: {exc}") from None


def _section_at(cls: type, data: Any, path: str) -> Any:
    """Build a sub-section; its errors (``loss.mean_loss: ...``) are re-rooted at ``path``."""
    if not isinstance(data, Mapping):
        raise LinkConfigError(f"{path}: must be a mapping, got {type(data).__name__}")
    names = {f.name for f in fields(cls)}
    for key in data:
        if key not in names:
            raise LinkConfigError(
                f"{path}.{key}: unknown field (known: {', '.join(sorted(names))})"
            )
    root = path.rsplit(".", 1)[0]
    try:
        return cls(**data)
    except LinkConfigError as exc:
        raise LinkConfigError(f"{root}.{exc}") from None
    except (TypeError, ValueError) as exc:
        raise LinkConfigError(f"{path}: {exc}") from None
