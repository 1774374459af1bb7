"""``[track]``: the SUMO network a vehicle drives on and where it starts."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, model_validator

from enn_traffic.config.base import XY, FilePath, Section


class TrackConfig(Section):
    """Where the vehicle drives: a SUMO network and a start pose on it. ``start_lane`` and
    ``start_edge`` may list several, and ``start_anywhere`` takes every lane; each traffic
    situation then draws one."""

    net: FilePath | None = Field(
        None, description="SUMO `.net.xml`; the drivable area is the union of its lane and "
        "junction shapes, its boundary the walls (holes under 0.2 m wide excepted); may be left "
        "out when `traffic.sumocfg` names one. Any path may be `pkg:PACKAGE/path` (a file inside "
        "an installed Python package)")
    start_xy: XY | None = Field(
        None, description="start position of the front-bumper point; give one of `start_xy`, "
        "`start_lane`, `start_edge`")
    start_heading_deg: float = Field(
        0.0, ge=-360, le=360, description="start heading with `start_xy` (0 = +x, "
        "counter-clockwise; -360 to 360)")
    start_lane: str | list[str] | None = Field(
        None, description="start on this lane's centre line, `start_offset` m from its beginning, "
        "facing along it; the lane must allow passenger cars. A list: each traffic situation "
        "draws one. `\"auto\"`: the lane the traffic demand uses most (`enn-traffic lanes` "
        "ranks them), at least `start_offset` + 10 m + the vehicle's length long")
    start_edge: str | list[str] | None = Field(
        None, description="start on this edge's rightmost lane that allows passenger cars. A list: "
        "each traffic situation draws one")
    start_anywhere: bool = Field(
        False, description="`true`: each traffic situation starts at a spot drawn from the whole "
        "track: every 5 m along every passenger lane's centre line, facing either way, where the "
        "vehicle's body has 1 m to the walls and 10 m free ahead (instead of `start_xy`, "
        "`start_lane`, `start_edge`)")
    start_offset: float = Field(
        10.0, ge=0, le=100_000,
        description="distance of a lane or edge start from the "
        "lane's beginning (m)")
    surface: Literal["passenger", "all"] = Field(
        "passenger", description="the road surface, whose edges are walls: `passenger` (the lanes "
        "that allow passenger cars, and the junctions they meet less their walking areas: "
        "sidewalks, bike lanes, tram tracks and railways are not road) or `all` (every lane and "
        "junction of the network)")
    fringe: Literal["wall", "exit"] | None = Field(
        None, description="`exit`: nodes with a single neighbouring node (where traffic enters or "
        "leaves the map) are exits, and reaching one ends a life as `left network`, its steps "
        "counted as fitness; `wall`: they are walls. Default: `exit` with SUMO traffic, `wall` "
        "otherwise (the only choice there)")
    traffic: dict[str, Any] = Field(
        {}, description="with several tracks (`[[track]]`): the `[traffic]` keys that differ on "
        "this one (`[track.traffic]`: its `starts_xy`, `routes`, `sumocfg` ...), replacing the "
        "scenario's")

    @model_validator(mode="after")
    def _one_start(self) -> TrackConfig:
        given = [v for v in (self.start_xy, self.start_lane, self.start_edge) if v is not None]
        if len(given) + self.start_anywhere != 1:
            raise ValueError("give exactly one of start_xy (with start_heading_deg), start_lane, "
                             "start_edge or start_anywhere = true")
        for name in ("start_lane", "start_edge"):
            if getattr(self, name) == []:
                raise ValueError(f"{name}: must name at least one {name.removeprefix('start_')}")
        return self

    @property
    def start_names(self) -> list[tuple[str, str]]:
        """The start lanes and edges as (kind, id) pairs: ``("lane", id)`` or ``("edge", id)``;
        empty for ``start_xy`` and ``start_anywhere``."""
        for kind in ("lane", "edge"):
            value = getattr(self, f"start_{kind}")
            if value is not None:
                return [(kind, v) for v in ([value] if isinstance(value, str) else value)]
        return []
