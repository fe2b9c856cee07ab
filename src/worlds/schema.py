"""The world YAML schema (pydantic v2) and its loader, whose errors name file, line and field.

One model per ``kind``; every model forbids unknown keys. Numbers the seed papers give are the
defaults and are cited where used; everything else is an implementer's choice, documented in
``docs/worlds.md``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

import yaml
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator

from worlds.yaml_source import node_at, validate_yaml


def _ordered(value: tuple[float, float]) -> tuple[float, float]:
    if value[0] > value[1]:
        raise ValueError(f"range must be (min, max) with min <= max, got {value}")
    return value


Range = Annotated[tuple[float, float], AfterValidator(_ordered)]
"""A (min, max) pair drawn uniformly from."""
XYPoint = tuple[float, float]
"""A point (east, north), m."""
Ring = Annotated[list[XYPoint], Field(min_length=3)]
"""A polygon's ring: at least three (east, north) points, m (closed implicitly)."""
PositiveXY = tuple[Annotated[float, Field(gt=0)], Annotated[float, Field(gt=0)]]
Colour = tuple[
    Annotated[float, Field(ge=0, le=1)],
    Annotated[float, Field(ge=0, le=1)],
    Annotated[float, Field(ge=0, le=1)],
    Annotated[float, Field(ge=0, le=1)],
]


class _Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    seed: int = Field(ge=0)
    """Seed of the world's single ``numpy.random.Generator``."""


class OffshoreSpec(_Spec):
    """Offshore oil-spill monitoring (seed 000 S1): sea, rig, helideck, tanker, spills, wind.

    Seed 000 gives 26 randomly placed spills found in 272 s, 48,000 m^2 covered; sizes, area and
    altitude are not given (digest 000 §S1), so the extent and spill sizes are choices.
    """

    kind: Literal["offshore"]
    size_m: PositiveXY = (800.0, 600.0)
    sea_rgba: Colour = (0.05, 0.22, 0.35, 1.0)
    wave_length_m: float = Field(8.0, gt=0)
    wave_amplitude_m: float = Field(0.5, ge=0)
    rig_deck_size_m: PositiveXY = (50.0, 40.0)
    rig_deck_height_m: float = Field(30.0, gt=0)
    helideck_diameter_m: float = Field(22.0, gt=0)
    tanker_length_m: float = Field(250.0, gt=0)
    tanker_beam_m: float = Field(45.0, gt=0)
    tanker_freeboard_m: float = Field(20.0, gt=0)
    tanker_distance_m: Range = (150.0, 250.0)
    spill_count: int = Field(26, ge=0)
    spill_radius_m: Range = (6.0, 20.0)
    spill_appear_s: Range = (0.0, 120.0)
    spill_clearance_m: float = Field(15.0, ge=0)
    wind_speed_m_s: float = Field(6.0, ge=0)
    wind_from_deg: float | None = None
    """Direction the wind blows from (0 = north); ``None``: drawn from the seed."""
    wind_gust_std_m_s: float = Field(1.5, ge=0)


class CitySpec(_Spec):
    """City mobile coverage (seed 000 S2): blocks of buildings, a land base, moving demand hotspots.

    City size, hotspot radius and dynamics are not given by seed 000 (digest §S2): defaults here.
    """

    kind: Literal["city"]
    size_m: PositiveXY = (600.0, 600.0)
    ground_rgba: Colour = (0.32, 0.32, 0.34, 1.0)
    blocks: tuple[Annotated[int, Field(ge=1)], Annotated[int, Field(ge=1)]] = (4, 4)
    street_width_m: float = Field(20.0, gt=0)
    lots_per_block_side: int = Field(2, ge=1)
    lot_setback_m: float = Field(3.0, ge=0)
    building_height_m: Range = (10.0, 80.0)
    land_base_radius_m: float = Field(15.0, gt=0)
    hotspot_count: int = Field(5, ge=0)
    hotspot_radius_m: Range = (20.0, 50.0)
    hotspot_speed_m_s: Range = (0.5, 2.0)


class IndoorSpec(_Spec):
    """Indoor plant search and rescue (seed 000 S3): rooms, doorways, machinery, pipes, people.

    Plant size and victim count are not given (digest 000 §S3). GPS-denied.
    """

    kind: Literal["indoor"]
    size_m: PositiveXY = (60.0, 40.0)
    """Outer size of the plant building; the world adds ``yard_m`` around it."""
    yard_m: float = Field(6.0, gt=0)
    floor_rgba: Colour = (0.5, 0.5, 0.47, 1.0)
    rooms: tuple[Annotated[int, Field(ge=1)], Annotated[int, Field(ge=1)]] = (3, 2)
    wall_height_m: float = Field(6.0, gt=0)
    wall_thickness_m: float = Field(0.3, gt=0)
    doorway_width_m: float = Field(1.5, gt=0)
    machinery_per_room: int = Field(2, ge=0)
    machinery_size_m: Range = (1.0, 3.0)
    machinery_height_m: Range = (1.0, 3.5)
    wall_clearance_m: float = Field(1.5, ge=0)
    """Free corridor kept along every wall so doorways stay reachable."""
    pipe_count: int = Field(3, ge=0)
    pipe_diameter_m: float = Field(0.3, gt=0)
    pipe_height_m: float = Field(4.5, gt=0)
    person_count: int = Field(4, ge=0)


class ArenaAcoSpec(_Spec):
    """Seed 001's ACO arena: 1 km x 1 km (Sec. 4.1) with static and randomly moving obstacles.

    Obstacle counts, sizes and speeds are not given (digest 004_001 §1); the defaults are choices.
    """

    kind: Literal["arena_aco"]
    size_m: PositiveXY = (1000.0, 1000.0)
    ground_rgba: Colour = (0.35, 0.45, 0.3, 1.0)
    static_obstacle_count: int = Field(25, ge=0)
    static_obstacle_size_m: Range = (10.0, 60.0)
    obstacle_height_m: Range = (20.0, 120.0)
    moving_obstacle_count: int = Field(8, ge=0)
    moving_obstacle_diameter_m: Range = (3.0, 10.0)
    moving_obstacle_speed_m_s: Range = (1.0, 5.0)
    moving_obstacle_altitude_m: Range = (10.0, 60.0)
    moving_obstacle_vertical_amplitude_m: float = Field(5.0, ge=0)
    zone_radius_m: float = Field(40.0, gt=0)
    """Radius of the start (west) and goal (east) zones kept free of static obstacles."""
    zone_separation_m: float | None = Field(None, gt=0)
    """Distance between the zones' centres, m, symmetric about the arena's centre on the
    east axis (default 0.8 x the width: the zones at -0.4 and +0.4 of it)."""
    moving_obstacle_region_m: tuple[float, float, float, float] | None = None
    """(east_min, north_min, east_max, north_max), m: where the drums start and between which
    they bounce (default the whole arena): a corridor between the zones, to make them dense
    where the vehicles fly."""

    @model_validator(mode="after")
    def _zones_and_region_fit(self) -> ArenaAcoSpec:
        sx, sy = self.size_m
        if self.zone_separation_m is not None and (
            self.zone_separation_m / 2.0 + self.zone_radius_m > sx / 2.0
        ):
            raise ValueError(
                f"zone_separation_m: {self.zone_separation_m} with zone_radius_m "
                f"{self.zone_radius_m} puts a zone outside the arena's width {sx}"
            )
        if self.zone_separation_m is not None and self.zone_separation_m < 2 * self.zone_radius_m:
            raise ValueError(
                f"zone_separation_m: {self.zone_separation_m} is less than two zone radii "
                f"({2 * self.zone_radius_m}): the zones overlap"
            )
        r = self.moving_obstacle_region_m
        if r is not None:
            big = self.moving_obstacle_diameter_m[1]
            if not (-sx / 2.0 <= r[0] and r[2] <= sx / 2.0 and -sy / 2.0 <= r[1]
                    and r[3] <= sy / 2.0):  # fmt: skip
                raise ValueError(
                    f"moving_obstacle_region_m: {list(r)} is not inside the arena "
                    f"(+-{sx / 2.0}, +-{sy / 2.0})"
                )
            if r[2] - r[0] <= big or r[3] - r[1] <= big:
                raise ValueError(
                    f"moving_obstacle_region_m: {list(r)} is not wider than the largest drum "
                    f"({big} m) in both directions"
                )
        return self


class WorkspaceMcoSpec(_Spec):
    """Seed 004's MCO workspace: a polygon with holes and zones of low interest (ZLIs).

    The paper's workspaces are 27-70 ha (Naranjos, Urban, Rejoya; digest 004_001 §5); the default
    extent (900 m x 780 m) holds a polygon of that order.
    """

    kind: Literal["workspace_mco"]
    size_m: PositiveXY = (900.0, 780.0)
    ground_rgba: Colour = (0.4, 0.5, 0.28, 1.0)
    vertex_count: int = Field(10, ge=3)
    radius_jitter: float = Field(0.25, ge=0, lt=1)
    hole_count: int = Field(2, ge=0)
    hole_radius_m: Range = (30.0, 70.0)
    low_interest_count: int = Field(3, ge=0)
    low_interest_radius_m: Range = (30.0, 80.0)
    outline_m: list[XYPoint] | None = Field(None, min_length=3)
    """An explicit outline (east, north; m), instead of the random star: a surveyed field. With it,
    ``holes_m`` and ``low_interest_m`` replace the random holes and zones, and the ``*_count``,
    ``*_radius_m``, ``vertex_count`` and ``radius_jitter`` fields are not used."""
    holes_m: list[Ring] = Field(default_factory=list)
    """No-fly holes of an explicit outline, each a ring of (east, north) points, m."""
    low_interest_m: list[Ring] = Field(default_factory=list)
    """Zones of low interest of an explicit outline, each a ring of (east, north) points, m."""
    launch_m: XYPoint | None = None
    """Where the fleet takes off (a ``start`` launch area there); None: the free point nearest
    the origin (``worlds.launch.default_area``)."""
    launch_radius_m: float = Field(15.0, gt=0)
    """Radius of the ``start`` launch area around ``launch_m``, m."""

    @model_validator(mode="after")
    def _explicit(self) -> WorkspaceMcoSpec:
        if self.outline_m is None and (self.holes_m or self.low_interest_m):
            raise ValueError("holes_m and low_interest_m need an explicit outline_m")
        return self


class TaskmapSpec(_Spec):
    """Seed 003's 2-D task map: tasks i.i.d. uniform on grid vertices with demands.

    Map size and graph are not given; the digest suggests a map of order 10 units (002_003 §NOT
    GIVEN), score amplitude a = 1000 for all tasks (Eq. 26), so demands default to 1000.
    """

    kind: Literal["taskmap"]
    size_m: PositiveXY = (10.0, 10.0)
    ground_rgba: Colour = (0.45, 0.45, 0.42, 1.0)
    grid_spacing_m: float = Field(0.5, gt=0)
    task_count: int = Field(20, ge=0)
    agent_count: int = Field(10, ge=0)
    demand: Range = (1000.0, 1000.0)


WorldSpec = OffshoreSpec | CitySpec | IndoorSpec | ArenaAcoSpec | WorkspaceMcoSpec | TaskmapSpec
SPEC_BY_KIND: dict[str, type[_Spec]] = {
    "offshore": OffshoreSpec,
    "city": CitySpec,
    "indoor": IndoorSpec,
    "arena_aco": ArenaAcoSpec,
    "workspace_mco": WorkspaceMcoSpec,
    "taskmap": TaskmapSpec,
}


class WorldSpecError(ValueError):
    """A world file that does not fit the schema; the message names file, line and field path."""


def parse_world(text: str, source: str = "<string>") -> WorldSpec:
    """Validate world YAML ``text`` (``source`` names it in errors): :class:`WorldSpecError`."""

    def model_of(data: dict[str, Any], root: yaml.Node) -> type[BaseModel]:
        kind = data.get("kind")
        if kind not in SPEC_BY_KIND:
            node, _ = node_at(root, ("kind",))
            what = "missing field" if kind is None else f"unknown kind {kind!r}"
            raise WorldSpecError(
                f"{source}:{node.start_mark.line + 1}: kind: {what}; one of {sorted(SPEC_BY_KIND)}"
            )
        return SPEC_BY_KIND[kind]

    return validate_yaml(  # type: ignore[return-value]
        text, source, model_of, WorldSpecError, "a world file is a mapping with 'kind' and 'seed'"
    )


def load_world(path: str | Path) -> WorldSpec:
    """Read and validate the world file at ``path``, before anything is built."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise WorldSpecError(f"{path}: cannot read world file: {exc}") from exc
    return parse_world(text, str(path))
