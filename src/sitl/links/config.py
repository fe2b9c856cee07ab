"""The link file: presets (link parameters, one or two directions) and link classes (role pairs).

``LinksConfig.load()`` reads the shipped ``presets.yaml``; ``LinksConfig.load(path)`` merges a
user's file over it (field by field: a user names only what changes), ``LinksConfig.load(path,
inline)`` a mapping of the same form over that (a scenario's ``links.presets`` and
``links.classes``), and validates everything at load, every error naming its field
(``presets.lte.up.loss.mean_loss: ...``, ``classes.edge-fog: unknown preset 'wifii'``). Format:
docs/links.md and presets.yaml.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from sitl.links.params import LinkConfigError, LinkParams, link_params_from_dict

PRESETS_PATH = Path(__file__).with_name("presets.yaml")
"""The shipped link file."""

ROLE_RANK: dict[str, int] = {"edge": 0, "fog": 1, "cloud": 2, "ground": 3}
"""Layer of each node role: a datagram toward a higher rank goes "up"."""

_PRESET_KEYS = {"base", "up", "down", "coverage", "sources"}
_TOP_KEYS = {"presets", "classes", "sources"}


@dataclass(frozen=True)
class CoverageCircle:
    """A disc of the horizontal plane where a node can use the link (an LTE cell, say)."""

    centre_enu_m: tuple[float, float]
    """East, north of the centre, m."""
    radius_m: float
    """Radius, m."""

    def __post_init__(self) -> None:
        centre = tuple(float(v) for v in self.centre_enu_m)
        if len(centre) != 2 or not all(math.isfinite(v) for v in centre):
            raise LinkConfigError("centre_enu_m: must be [east, north] in m")
        object.__setattr__(self, "centre_enu_m", centre)
        r = self.radius_m
        if isinstance(r, bool) or not isinstance(r, (int, float)) or not r > 0 or r == math.inf:
            raise LinkConfigError(f"radius_m: must be > 0 m, got {r!r}")

    def contains(self, east_m: float, north_m: float) -> bool:
        """Whether the horizontal point lies inside the disc (the edge included)."""
        de = east_m - self.centre_enu_m[0]
        dn = north_m - self.centre_enu_m[1]
        return de * de + dn * dn <= self.radius_m * self.radius_m


@dataclass(frozen=True)
class LinkPreset:
    """A named link: parameters up (toward the higher layer) and down, and its coverage."""

    name: str
    up: LinkParams
    down: LinkParams
    coverage: tuple[CoverageCircle, ...] = ()
    """Empty: the link reaches everywhere."""

    def covers(self, east_m: float, north_m: float) -> bool:
        """Whether a node at this horizontal position can use the link."""
        return not self.coverage or any(c.contains(east_m, north_m) for c in self.coverage)


def _merge(base: Any, over: Any) -> Any:
    """``over`` merged into a copy of ``base``: mappings recursively, anything else replaced."""
    if isinstance(base, Mapping) and isinstance(over, Mapping):
        out = dict(base)
        for key, value in over.items():
            out[key] = _merge(base[key], value) if key in base else copy.deepcopy(value)
        return out
    return copy.deepcopy(over)


def canonical_class(role_a: str, role_b: str) -> str:
    """The class name of a role pair: lower layer first (``fog-edge`` -> ``edge-fog``)."""
    for role in (role_a, role_b):
        if role not in ROLE_RANK:
            raise LinkConfigError(f"unknown role {role!r} (known: {', '.join(ROLE_RANK)})")
    lo, hi = sorted((role_a, role_b), key=ROLE_RANK.__getitem__)
    return f"{lo}-{hi}"


def _class_key(name: Any, path: str) -> str:
    parts = name.split("-") if isinstance(name, str) else []
    if len(parts) != 2 or not all(p in ROLE_RANK for p in parts):
        raise LinkConfigError(
            f"{path}: unknown class {name!r} (a pair of roles {', '.join(ROLE_RANK)}, "
            "such as edge-fog)"
        )
    return canonical_class(parts[0], parts[1])


def _resolve_base(name: str, raw: Mapping[str, Any], seen: tuple[str, ...] = ()) -> dict:
    """The preset's mapping with its ``base:`` chain applied (the base first)."""
    data = raw[name]
    if not isinstance(data, Mapping):
        raise LinkConfigError(f"presets.{name}: must be a mapping, got {type(data).__name__}")
    base = data.get("base")
    if base is None:
        return dict(data)
    if not isinstance(base, str):
        raise LinkConfigError(f"presets.{name}.base: must be a preset name, got {base!r}")
    if base not in raw:
        raise LinkConfigError(f"presets.{name}.base: unknown preset {base!r}")
    if base in seen or base == name:
        raise LinkConfigError(f"presets.{name}.base: circular base {' -> '.join((*seen, name))}")
    parent = _resolve_base(base, raw, (*seen, name))
    parent.pop("sources", None)  # each preset cites its own numbers; the base's stay with it
    data = {k: v for k, v in data.items() if k != "base"}
    return _merge(parent, data)


def _build_preset(name: str, data: Mapping[str, Any]) -> LinkPreset:
    path = f"presets.{name}"
    shared = {k: v for k, v in data.items() if k not in _PRESET_KEYS}
    has_up, has_down = "up" in data, "down" in data
    if has_up != has_down:
        missing = "down" if has_up else "up"
        raise LinkConfigError(f"{path}.{missing}: give both up and down (or neither)")
    if has_up:
        for side in ("up", "down"):
            if not isinstance(data[side], Mapping):
                raise LinkConfigError(f"{path}.{side}: must be a mapping")
        for key in shared:
            if key != "sources" and key in data["up"] and key in data["down"]:
                raise LinkConfigError(
                    f"{path}.{key}: {name} sets {key} per direction; set {path}.up.{key} and "
                    f"{path}.down.{key} instead"
                )
        up = link_params_from_dict(_merge(shared, data["up"]), f"{path}.up")
        down = link_params_from_dict(_merge(shared, data["down"]), f"{path}.down")
    else:
        up = down = link_params_from_dict(shared, path)
    circles = data.get("coverage") or []
    if not isinstance(circles, list):
        raise LinkConfigError(f"{path}.coverage: must be a list of circles")
    coverage = []
    for k, circle in enumerate(circles):
        where = f"{path}.coverage[{k}]"
        if not isinstance(circle, Mapping) or set(circle) != {"centre_enu_m", "radius_m"}:
            raise LinkConfigError(f"{where}: needs exactly centre_enu_m [east, north] and radius_m")
        try:
            coverage.append(CoverageCircle(tuple(circle["centre_enu_m"]), circle["radius_m"]))
        except LinkConfigError as exc:
            raise LinkConfigError(f"{where}.{exc}") from None
        except (TypeError, ValueError) as exc:
            raise LinkConfigError(f"{where}: {exc}") from None
    return LinkPreset(name, up, down, tuple(coverage))


@dataclass(frozen=True)
class LinksConfig:
    """Validated link presets and the preset of each link class."""

    presets: Mapping[str, LinkPreset]
    classes: Mapping[str, str]
    """Class name (``edge-fog``, lower layer first; ``ground-X``) -> preset name."""
    origin: str = "presets.yaml"
    """Where the user part came from (errors and reports)."""

    @classmethod
    def load(
        cls, path: str | Path | None = None, inline: Mapping[str, Any] | None = None
    ) -> LinksConfig:
        """The shipped presets, the link file at ``path`` merged over them, then ``inline``.

        ``inline`` is a link file's mapping (``presets``, ``classes``), merged over the file
        exactly as the file is over the shipped presets.

        Raises:
            LinkConfigError: unreadable file or a bad field (the message names the field; an
                error of the file's starts with its path, one of ``inline`` with the field).
        """
        if path is None:
            if inline is None:
                return cls.from_dict({}, origin=str(PRESETS_PATH))
            return cls.from_layers([inline], origin="inline")
        data = cls._read(Path(path))
        config = cls._from_file(path, data)  # the file's own errors name the file
        if inline is None:
            return config
        return cls.from_layers([data, inline], origin=f"{path} + inline")

    @classmethod
    def _from_file(cls, path: str | Path, data: Mapping[str, Any]) -> LinksConfig:
        try:
            return cls.from_dict(data, origin=str(path))
        except LinkConfigError as exc:
            raise LinkConfigError(f"{path}: {exc}") from None

    @staticmethod
    def _read(path: Path) -> Mapping[str, Any]:
        """The link file's mapping ({} for an empty file)."""
        try:
            text = path.read_text()
        except OSError as exc:
            raise LinkConfigError(f"{path}: cannot read the link file ({exc})") from None
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise LinkConfigError(f"{path}: not valid YAML ({exc})") from None
        return data if data is not None else {}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], origin: str = "<dict>") -> LinksConfig:
        """The shipped presets with ``data`` (a link file's mapping) merged over them."""
        return cls.from_layers([data], origin)

    @classmethod
    def from_layers(
        cls, layers: Sequence[Mapping[str, Any]], origin: str = "<dict>"
    ) -> LinksConfig:
        """The shipped presets with each of ``layers`` (link files' mappings) merged over, in turn.

        Presets merge field by field, layer over layer; each layer's classes replace the earlier
        ones' (null removes a class).
        """
        for data in layers:
            if not isinstance(data, Mapping):
                raise LinkConfigError(f"link file must be a mapping, got {type(data).__name__}")
            for key in data:
                if key not in _TOP_KEYS:
                    raise LinkConfigError(f"{key}: unknown section (known: {', '.join(_TOP_KEYS)})")
            for section in ("presets", "classes"):
                if section in data and not isinstance(data[section], Mapping):
                    raise LinkConfigError(f"{section}: must be a mapping")
        shipped = yaml.safe_load(PRESETS_PATH.read_text())
        raw_presets = shipped["presets"]
        for data in layers:
            raw_presets = _merge(raw_presets, data.get("presets", {}))
        presets = {
            name: _build_preset(name, _resolve_base(name, raw_presets)) for name in raw_presets
        }
        classes: dict[str, str] = {}
        for source in (shipped["classes"], *(data.get("classes", {}) for data in layers)):
            given: set[str] = set()
            for name, preset in source.items():
                path = f"classes.{name}"
                key = _class_key(name, path)
                if key in given:
                    raise LinkConfigError(f"{path}: the class {key} is given twice")
                given.add(key)
                if preset is None:  # a user removes a class: no link between those roles
                    classes.pop(key, None)
                    continue
                if not isinstance(preset, str):
                    raise LinkConfigError(
                        f"{path}: must be a preset name (or null: no link), got {preset!r}"
                    )
                if preset not in presets:
                    raise LinkConfigError(f"{path}: unknown preset {preset!r}")
                classes[key] = preset
        return cls(presets=presets, classes=classes, origin=origin)

    def preset(self, name: str) -> LinkPreset:
        """The preset called ``name``.

        Raises:
            LinkConfigError: no such preset.
        """
        try:
            return self.presets[name]
        except KeyError:
            raise LinkConfigError(
                f"unknown preset {name!r} (known: {', '.join(sorted(self.presets))})"
            ) from None

    def class_preset(self, class_name: str) -> LinkPreset | None:
        """The preset of a link class (either role order), None when the class has no link."""
        preset = self.classes.get(_class_key(class_name, "class"))
        return None if preset is None else self.presets[preset]

    def link(self, name: str) -> tuple[LinkParams, LinkParams]:
        """(up, down) parameters of a link class (``edge-fog``) or else of a preset (``lte``)."""
        if isinstance(name, str) and name not in self.presets and "-" in name:
            preset = self.class_preset(name)
            if preset is None:
                raise LinkConfigError(f"class {name}: no link configured")
            return preset.up, preset.down
        preset = self.preset(name)
        return preset.up, preset.down
