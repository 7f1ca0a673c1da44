"""The typed safety case: the value `safety_case.load_case` returns and every later stage reads.

These models are the contract between packages. They hold what the YAML says, already
validated and normalised (durations in seconds, thresholds split into operator and value), plus
the source positions (`Mark`) that later stages need to point errors back into the YAML.
"""

from __future__ import annotations

from enum import Enum
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field


class Mark(BaseModel):
    """A 1-based line and column in the YAML source."""

    model_config = ConfigDict(frozen=True)
    line: int = 0
    col: int = 0
    #: the file, for a node written in a module the case `uses` (empty: the case file itself)
    path: str = ""


class NodeType(str, Enum):  # noqa: UP042 - keep str() and format() as they are
    """GSN node types, keyed by the id prefix gsn2x uses."""

    GOAL = "G"
    STRATEGY = "S"
    SOLUTION = "Sn"
    CONTEXT = "C"
    ASSUMPTION = "A"
    JUSTIFICATION = "J"
    COUNTER_GOAL = "CG"
    COUNTER_SOLUTION = "CSn"


class MetricParams(BaseModel):
    """Parameters of the built-in metrics; defaults are those of `docs/spi-reference.md`.

    Every parameter declares a lower and an upper bound here, next to its definition: generous,
    but finite, so `.inf`, `1e5000` or a window of 10^12 ticks is refused by `check` (CW012)
    instead of switching a metric off or exhausting memory. `docs/safety-case-language.md`
    lists the same bounds; a test keeps the two in step and fails for a parameter without both.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)
    pairing_gate: float = Field(
        3.0, gt=0, le=100, description="max centre distance to pair objects [m]"
    )
    trajectory_decay: float = Field(0.95, gt=0, le=1, description="k in w_n = k^(n-1)")
    comfort_steepness: float = Field(0.2, gt=0, le=100, description="w in NV(s)")
    els_window: int = Field(5, ge=2, le=10_000, description="ticks in the ELS moving variance")
    plan_history: int = Field(10, ge=1, le=1_000, description="stored plans for chpps")
    prediction_tolerance: float = Field(1.0, gt=0, le=100, description="ompv hit radius [m]")
    comfort_span: float = Field(
        3.0, gt=0, le=60, description="time span [s] of the cubic fits behind hcs and ppcs"
    )
    pet_ref: float = Field(2.0, gt=0, le=60, description="post-encroachment time reference [s]")
    max_gap: float = Field(0.5, gt=0, le=60, description="gap [s] after which history restarts")
    resample_step: float = Field(
        0.1,
        ge=0.01,
        le=10,
        description="step [s] of the time grid plans and predictions are resampled to",
    )
    coverage_margin: float = Field(
        2.0, ge=0, le=100, description="objects this close [m] to a coverage edge are not compared"
    )
    lane_half_width: float = Field(
        1.75, gt=0, le=10, description="half width [m] of the corridor of the leader and follower"
    )
    lone_horizon: float = Field(
        2.0,
        gt=0,
        le=60,
        description="time [s] after which an unpaired object counts as a full disagreement",
    )
    plan_lat_horizon: float = Field(
        2.0, gt=0, le=60, description="plan time [s] over which plan_lat compares the plans"
    )
    ompv_lookback: float = Field(
        0.1,
        gt=0,
        le=10,
        description="age [s] of the observation whose predictions ompv checks",
    )
    standing_motion: float = Field(
        0.0,
        ge=0,
        le=100,
        description="objects moving less [m] over the compared time are left out of ots, ompv",
    )
    ols_range_scale: float = Field(
        0.0,
        ge=0,
        le=10_000,
        description="ols divides a pair's distance by 1 + range / this [m] (0: off)",
    )
    ots_time_scale: float = Field(
        0.0,
        ge=0,
        le=600,
        description="ots divides each point's distance by 1 + dt / this [s] (0: off)",
    )
    ets_relative: int = Field(
        0,
        ge=0,
        le=1,
        description="1: ets compares each plan relative to its channel's ego position",
    )
    plan_smoothing: float = Field(
        0.0,
        ge=0,
        le=10,
        description="span [s] of the quadratic fits that smooth a plan's sample noise (0: off)",
    )
    plan_standstill: float = Field(
        0.0,
        ge=0,
        le=10,
        description="a plan within this distance [m] of its first point stands at that point",
    )


class Threshold(BaseModel):
    """`">= 0.6"` parsed: the SPI holds while `signal OP value`."""

    model_config = ConfigDict(frozen=True)
    op: Literal[">=", "<=", ">", "<"]
    value: float

    def __str__(self) -> str:
        return f"{self.op} {self.value:g}"


class SpiBinding(BaseModel):
    """`spi:` on a solution: either `signal` + `threshold` (+ optional `for`) or a raw `stl`."""

    model_config = ConfigDict(frozen=True)
    signal: str | None = None
    threshold: Threshold | None = None
    for_seconds: float | None = None  # the YAML key is `for`
    stl: str | None = None
    merge_gap: float | None = None  # seconds; None = the case default
    min_duration: float | None = None  # seconds; None = the case default
    # near-miss margin in robustness units: 0 <= robustness < warn forms near_miss episodes
    warn: float | None = None
    mark: Mark = Mark()  # position of the `spi:` key
    formula_mark: Mark = Mark()  # position of the `stl` / `signal` value (formula text start)


class HazardBinding(BaseModel):
    """`hazard:` on a counter-solution: while `when` holds, the challenged claims are in doubt."""

    model_config = ConfigDict(frozen=True)
    when: str
    merge_gap: float | None = None
    min_duration: float | None = None
    warn: float | None = None  # near-miss margin (robustness units of `not when`)
    mark: Mark = Mark()
    formula_mark: Mark = Mark()  # position of the `when` value (of `use` for a library rule)
    use: str | None = None  # the traffic rule of the library it instantiates
    params: dict[str, int | float | str] = {}  # that rule's parameters, resolved
    from_library: bool = False  # `when` came from the library: findings point at `use`


class ContractBinding(BaseModel):
    """`contract:` on a solution: an assume-guarantee pair of formulas. The contract is violated
    only at ticks where the assumption holds and the guarantee fails; where the assumption
    fails it is "outside assumption", neither a pass nor a violation (docs/contracts.md).

    `assume` / `guarantee` hold the final formula text: a library contract (`use:`) is expanded
    by the loader with its parameters (`safety_case.contracts`)."""

    model_config = ConfigDict(frozen=True)
    guarantee: str
    assume: str | None = None
    use: str | None = None  # the library contract it instantiates (`contracts/<name>` text)
    params: dict[str, int | float | str] = {}  # every parameter of a library contract, resolved
    merge_gap: float | None = None
    min_duration: float | None = None
    warn: float | None = None
    mark: Mark = Mark()  # the `contract:` key
    #: where column 1 of each formula sits; for a library contract, the `use:` value (the
    #: text is the library's, so findings point at the use, not into the text)
    guarantee_mark: Mark = Mark()
    assume_mark: Mark = Mark()
    #: the formula text came from the library: findings point at the mark, not into the text
    guarantee_from_library: bool = False
    assume_from_library: bool = False


OddValue = str | float | bool


class OddRange(BaseModel):
    """A numeric attribute's accepted interval (either end optional, both inclusive)."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    min: float | None = None
    max: float | None = None


class OddSpec(BaseModel):
    """An Operational Design Domain: the conditions under which the argument claims to hold
    (`odd:` on a context node, docs/odd.md). A tick is inside when every attribute is reported
    with an accepted value and, when `combinations` are listed, the conditions match one."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    name: str = ""
    #: attribute (`environment.weather`, or a signal name such as `ego_speed`) -> accepted
    #: values (a list) or interval
    attributes: dict[str, list[OddValue] | OddRange] = {}
    #: accepted combinations of attribute values (each a partial assignment); empty: any
    combinations: list[dict[str, OddValue]] = []
    source: str = ""  # the file it was read from ("" when inline)


class Node(BaseModel):
    """One GSN node."""

    model_config = ConfigDict(frozen=True)
    id: str
    type: NodeType
    text: str
    supported_by: list[str] = []
    in_context_of: list[str] = []
    challenges: list[str] = []
    #: relations this counter node challenges (gsn2x's `challenges: G2 -> CG1`), as
    #: (from, to) pairs; drawn and exported, not judged (docs/gsn2x.md)
    challenged_relations: list[tuple[str, str]] = []
    undeveloped: bool = False
    url: str | None = None
    spi: SpiBinding | None = None
    hazard: HazardBinding | None = None
    contract: ContractBinding | None = None  # on a solution (Sn), instead of `spi`
    odd: OddSpec | None = None  # on a context node (C): the ODD its goals are claimed in
    #: gsn2x presentation attributes kept as written (classes, level, horizontalIndex,
    #: rankIncrement, nodeType, acp, ...) and its layers (any other key), for export-gsn
    gsn: dict = {}
    mark: Mark = Mark()  # position of the node id key
    # YAML key (`supportedBy`, `undeveloped`, ...) -> position of that key in this node.
    key_marks: dict[str, Mark] = {}
    # relation (`supportedBy`, `inContextOf`, `challenges`) -> target id -> position of the
    # reference, so structural checks point at the exact list item.
    ref_marks: dict[str, dict[str, Mark]] = {}


class Module(BaseModel):
    model_config = ConfigDict(frozen=True)
    name: str
    brief: str = ""
    uses: list[str] = []  # gsn2x: the module files this one uses (relative to it)
    #: gsn2x: the module's other attributes as written (additionalInformation, ...)
    gsn: dict = {}


class ChannelCoverage(BaseModel):
    """What one channel can see (`monitor.coverage.<channel>`): a field of view centred on its
    ego heading and a range; the cross-channel object metrics compare only what both channels
    of a pair can see (docs/spi-reference.md, "Channel coverage")."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    fov_deg: float = Field(360.0, gt=0, le=360, description="field of view [degrees]")
    range_m: float | None = Field(
        None, gt=0, le=1e5, description="sensing range [m]; none: unlimited"
    )


class ScoringParams(BaseModel):
    """`monitor.scoring:` the parameters of the penalty score (eqs. 6.1 and 6.3 of the CARLA
    safety-monitor thesis, named and bounded as it does) and of the CARLA Leaderboard score of
    a drive (docs/traffic-rules.md). Penalties and coefficients default to the traffic-rules
    library's; these override them per rule (`collision` per party: `collision.pedestrian`)."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    d: float = Field(
        100.0,
        ge=0,
        le=1000,
        description="d: difficulty of the scenario, 0 to 1000 "
        "(eq. 6.1; a stream has no scenario file, so the case sets it)",
    )
    alpha: float = Field(
        0.2,
        ge=0,
        le=1,
        description="alpha: intensity of traffic, 0 (empty road) to 1 (gridlock) (eq. 6.3)",
    )
    gamma: float = Field(
        0.7, gt=0, le=1, description="gamma: discount factor of the penalties, (0, 1] (eq. 6.1)"
    )
    v_avg: float | None = Field(
        None,
        gt=0,
        le=100,
        description="v_avg: average speed limit "
        "over the route [m/s]; none: from the stream's speed limits",
    )
    route_length: float | None = Field(
        None,
        gt=0,
        le=1e7,
        description="s: length of the route [m]; none: the stream's world.route.length",
    )
    stop_allowance: float = Field(
        12.0,
        ge=0,
        le=3600,
        description="t_avg: time [s] allowed at "
        "each stop line passed (the thesis' evaluation: 12 s a junction)",
    )
    stops: list[Annotated[float, Field(ge=0, le=3600)]] | None = Field(
        None,
        max_length=10000,
        description="t_avg of every stop of the route [s], instead of "
        "stop_allowance per stop line passed",
    )
    timeliness_cap: bool = Field(
        False,
        description="casewatch's variant: cap t_o / t at 1 "
        "(no points for beating the optimal time)",
    )
    neither: float = Field(
        50.0,
        ge=0,
        le=1e4,
        description="penalty for neither low beam at "
        "night nor fog lights in fog at once (instead of both penalties)",
    )
    penalties: dict[str, tuple[float, float]] = {}  # rule -> (base, while speeding)
    carla: dict[str, float] = {}  # rule -> CARLA infraction coefficient in (0, 1]
    min_speed_checkpoints: int = Field(
        4,
        ge=1,
        le=100,
        description="stretches of the route the "
        "Leaderboard's minimum-speed test compares speeds over",
    )


class MonitorConfig(BaseModel):
    """The `monitor:` block: what is observed and how often."""

    model_config = ConfigDict(frozen=True)
    channels: list[str]
    period: float = 0.1  # seconds
    signals: dict[str, str] = {}  # declared stream signals: name -> description
    metrics: MetricParams = MetricParams()
    coverage: dict[str, ChannelCoverage] = {}  # channel -> what it can see (default: all)
    merge_gap: float = 1.0  # seconds; episodes closer than this merge
    min_duration: float = 0.0  # seconds; shorter episodes are dropped (and counted)
    #: the topic mapping for ROS 2 bags, as written: a path relative to the case, or inline
    #: (checked when a bag is read: monitor.bags.mapping, docs/bags.md); None: not given
    topics: str | dict | None = None
    scoring: ScoringParams = ScoringParams()
    mark: Mark = Mark()


class Case(BaseModel):
    """A loaded safety case. `nodes` keeps the YAML order."""

    model_config = ConfigDict(frozen=True)
    path: str
    digest: str  # sha256 of the file bytes
    module: Module
    monitor: MonitorConfig
    nodes: dict[str, Node]

    def root_id(self) -> str:
        """The single root goal (checks guarantee there is exactly one in a loaded case)."""
        supported = {c for n in self.nodes.values() for c in n.supported_by}
        roots = [
            n.id for n in self.nodes.values() if n.type is NodeType.GOAL and n.id not in supported
        ]
        return roots[0]
