"""The wire types, kept by hand to match ``idl/paramdds.idl`` exactly.

``tests/dds/test_idl_identity.py`` compiles the IDL and compares XTypes type
identifiers with these classes, so the two cannot drift apart. Every struct is
``@final`` (plain XCDR1, which every vendor reads), so a type cannot grow: a
breaking change gets a new IDL module on new topic names (docs/wire.md, "How
the types evolve").

Values follow rcl_interfaces: a ``type`` byte and one member per type.
"""

from dataclasses import dataclass, field

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import final, key
from cyclonedds.idl.types import bounded_str, byte, float64, int32, int64, sequence, uint32, uint64

from paramdds.dds.wire import typecache
from paramdds.dds.wire.cdr import fast_cdr

MAX_KEY_LEN = 255  # bytes of UTF-8, for node ids and parameter names (written as a literal
# in the annotations below: the cyclonedds mypy plugin needs `bounded_str[<int literal>]`)

# ParameterEvent.kind
EVENT_PARAMETER = 0  # one parameter's current value and descriptor
EVENT_PRESENCE = 1  # the node itself: host, pid, revision, parameter count; name is ""
# a presence sample's value: NOT_SET, or a string array of "name=value" tags about the server
# ("request_filter=native" or "=handler", see filters.filter_tag); readers ignore tags they do not know


@fast_cdr
@dataclass
@final
class ParameterValue(IdlStruct, typename="paramdds.ParameterValue"):
    """A value: ``type`` (rcl_interfaces' ParameterType numbering) and the member of that type."""

    type: byte = 0
    bool_value: bool = False
    integer_value: int64 = 0
    double_value: float64 = 0.0
    string_value: str = ""
    byte_array_value: sequence[byte] = field(default_factory=list)
    bool_array_value: sequence[bool] = field(default_factory=list)
    integer_array_value: sequence[int64] = field(default_factory=list)
    double_array_value: sequence[float64] = field(default_factory=list)
    string_array_value: sequence[str] = field(default_factory=list)


@fast_cdr
@dataclass
@final
class IntegerRange(IdlStruct, typename="paramdds.IntegerRange"):
    """An integer parameter's inclusive range, and its step (0: any value in range)."""

    from_value: int64 = 0
    to_value: int64 = 0
    step: uint64 = 0


@fast_cdr
@dataclass
@final
class FloatingPointRange(IdlStruct, typename="paramdds.FloatingPointRange"):
    """A double parameter's inclusive range, and its step (0.0: any value in range)."""

    from_value: float64 = 0.0
    to_value: float64 = 0.0
    step: float64 = 0.0


@fast_cdr
@dataclass
@final
class Validator(IdlStruct, typename="paramdds.Validator"):
    """A generate_parameter_library validator: its name and its arguments."""

    kind: str = ""
    args: sequence[ParameterValue] = field(default_factory=list)


@fast_cdr
@dataclass
@final
class ParameterDescriptor(IdlStruct, typename="paramdds.ParameterDescriptor"):
    """rcl_interfaces' ParameterDescriptor, with the spec's validators."""

    name: str = ""
    type: byte = 0
    description: str = ""
    additional_constraints: str = ""
    read_only: bool = False
    dynamic_typing: bool = False
    integer_range: sequence[IntegerRange, 1] = field(default_factory=list)
    floating_point_range: sequence[FloatingPointRange, 1] = field(default_factory=list)
    validators: sequence[Validator] = field(default_factory=list)


@fast_cdr
@dataclass
@final
class Parameter(IdlStruct, typename="paramdds.Parameter"):
    """A parameter of a set request: its name and its new value."""

    name: str = ""
    value: ParameterValue = field(default_factory=ParameterValue)


@fast_cdr
@dataclass
@final
class Time(IdlStruct, typename="paramdds.Time"):
    """A writer's clock: seconds and nanoseconds since the Unix epoch."""

    sec: int32 = 0
    nanosec: uint32 = 0


@fast_cdr
@dataclass
@final
class ParameterEvent(IdlStruct, typename="paramdds.ParameterEvent"):
    """State of one parameter of one node (kind 0), or the node's presence (kind 1)."""

    node_id: bounded_str[255] = ""
    key("node_id")
    name: bounded_str[255] = ""
    key("name")
    kind: byte = EVENT_PARAMETER
    revision: int64 = 0
    stamp: Time = field(default_factory=Time)
    value: ParameterValue = field(default_factory=ParameterValue)
    # empty when the descriptor is only (name, value type): see convert.state_descriptor_to_wire
    descriptor: sequence[ParameterDescriptor, 1] = field(default_factory=list)
    host: str = ""
    pid: int32 = 0
    parameter_count: uint32 = 0
    # random, non-zero, new each time a server starts hosting the node: with the revision it
    # never repeats (a revision alone does after a restart); 0 from a writer that has none
    incarnation: uint64 = 0
    # blame (kind 0): who made this change, whether the node verified it, through what;
    # with stamp (when) and revision (which change). "" from a writer that keeps none
    who: str = ""
    verified: bool = False
    via: str = ""


@fast_cdr
@dataclass
@final
class SetParametersRequest(IdlStruct, typename="paramdds.SetParametersRequest"):
    """A set of parameters of one node (each on its own, or ``atomic``)."""

    node_id: bounded_str[255] = ""
    key("node_id")
    client_id: uint64 = 0
    request_id: uint64 = 0
    atomic: bool = False
    expected_revision: int64 = -1  # -1: no compare-and-set
    retained: bool = False  # an assignment (TRANSIENT_LOCAL, never on the interactive path)
    parameters: sequence[Parameter] = field(default_factory=list)
    expected_incarnation: uint64 = 0  # 0: compare the revision alone (when expected_revision >= 0)
    # ns since the Unix epoch (caller's clock) after which the node must not apply it; 0: none
    deadline: int64 = 0
    who: str = ""  # a claim, unless DDS Security authenticates the asker
    via: str = ""  # cli, api, web, zenoh, foxglove, ros2, load, assign, start


@fast_cdr
@dataclass
@final
class SetParameterResult(IdlStruct, typename="paramdds.SetParameterResult"):
    """What a set did to one parameter."""

    name: str = ""
    successful: bool = False
    reason: str = ""
    code: str = ""  # an ErrorCode name, "" on success


@fast_cdr
@dataclass
@final
class SetParametersResponse(IdlStruct, typename="paramdds.SetParametersResponse"):
    """A node's answer to one set request, for the client that sent it."""

    node_id: bounded_str[255] = ""
    key("node_id")
    client_id: uint64 = 0
    request_id: uint64 = 0
    revision: int64 = 0
    code: str = ""  # a failure of the whole request (TOO_LARGE, INVALID_VALUE…), "" otherwise
    reason: str = ""
    results: sequence[SetParameterResult] = field(default_factory=list)
    incarnation: uint64 = 0  # the node's, with revision (on CONFLICT: its current one)


@fast_cdr
@dataclass
@final
class HistoryQuery(IdlStruct, typename="paramdds.HistoryQuery"):
    """A question to a node's history: records after ``after_seq`` matching every filter."""

    since_revision: int64 = -1  # < 0: any
    since_time: int64 = 0  # ns since the Unix epoch, 0: any
    until_time: int64 = 0  # likewise
    who: str = ""  # a glob, "": anyone
    outcome: byte = 0  # 0 applied and refused, 1 applied, 2 refused
    limit: uint32 = 0  # records per reply at most, 0: the node's page size
    after_seq: uint64 = 0


@fast_cdr
@dataclass
@final
class GetParametersRequest(IdlStruct, typename="paramdds.GetParametersRequest"):
    """A get of named parameters of one node (with their descriptors if asked), or of its history."""

    node_id: bounded_str[255] = ""
    key("node_id")
    client_id: uint64 = 0
    request_id: uint64 = 0
    with_descriptors: bool = False
    names: sequence[str] = field(default_factory=list)
    history: sequence[HistoryQuery, 1] = field(default_factory=list)


@fast_cdr
@dataclass
@final
class LastChange(IdlStruct, typename="paramdds.LastChange"):
    """Who last changed a parameter, whether verified, through what, when, at which revision."""

    who: str = ""
    verified: bool = False
    via: str = ""
    stamp: Time = field(default_factory=Time)
    revision: int64 = 0


@fast_cdr
@dataclass
@final
class GetParameterResult(IdlStruct, typename="paramdds.GetParameterResult"):
    """One name's value (and descriptor), or why there is none."""

    name: str = ""
    code: str = ""  # "" when found, else NOT_FOUND / INVALID_NAME
    reason: str = ""
    value: ParameterValue = field(default_factory=ParameterValue)
    descriptor: sequence[ParameterDescriptor, 1] = field(default_factory=list)
    last_change: sequence[LastChange, 1] = field(default_factory=list)  # with descriptors


@fast_cdr
@dataclass
@final
class HistoryRecord(IdlStruct, typename="paramdds.HistoryRecord"):
    """A change a node applied to one parameter, or a write it refused."""

    seq: uint64 = 0
    name: str = ""
    revision: int64 = 0
    stamp: Time = field(default_factory=Time)
    who: str = ""
    verified: bool = False
    via: str = ""
    old_value: sequence[ParameterValue, 1] = field(default_factory=list)  # empty: did not exist
    new_value: sequence[ParameterValue, 1] = field(default_factory=list)  # empty: deleted
    applied: bool = False
    code: str = ""
    reason: str = ""


@fast_cdr
@dataclass
@final
class GetParametersResponse(IdlStruct, typename="paramdds.GetParametersResponse"):
    """A node's answer to one get request, for the client that sent it."""

    node_id: bounded_str[255] = ""
    key("node_id")
    client_id: uint64 = 0
    request_id: uint64 = 0
    revision: int64 = 0
    code: str = ""
    reason: str = ""
    results: sequence[GetParameterResult] = field(default_factory=list)
    incarnation: uint64 = 0
    history: sequence[HistoryRecord] = field(default_factory=list)
    history_kept: bool = False  # False: the node keeps no history
    history_more: bool = False  # more records match: ask again after the last seq
    history_compacted: bool = False  # retention dropped records the query asks for


@fast_cdr
@dataclass
@final
class ListParametersRequest(IdlStruct, typename="paramdds.ListParametersRequest"):
    """A list of one node's parameter names under ``prefixes``, to ``depth`` (0: any)."""

    node_id: bounded_str[255] = ""
    key("node_id")
    client_id: uint64 = 0
    request_id: uint64 = 0
    depth: uint64 = 0
    prefixes: sequence[str] = field(default_factory=list)


@fast_cdr
@dataclass
@final
class ListParametersResponse(IdlStruct, typename="paramdds.ListParametersResponse"):
    """A node's answer to one list request, for the client that sent it."""

    node_id: bounded_str[255] = ""
    key("node_id")
    client_id: uint64 = 0
    request_id: uint64 = 0
    revision: int64 = 0
    code: str = ""
    reason: str = ""
    names: sequence[str] = field(default_factory=list)
    prefixes: sequence[str] = field(default_factory=list)
    incarnation: uint64 = 0


# topic name -> type, in the order of docs/wire.md's table
TOPICS: dict[str, type[IdlStruct]] = {
    "ParameterEvents": ParameterEvent,
    "SetParametersRequest": SetParametersRequest,
    "SetParametersResponse": SetParametersResponse,
    "GetParametersRequest": GetParametersRequest,
    "GetParametersResponse": GetParametersResponse,
    "ListParametersRequest": ListParametersRequest,
    "ListParametersResponse": ListParametersResponse,
}

# the XTypes type data of these types, precomputed (saves ~130 ms per process: see typecache.py)
typecache.install(list(TOPICS.values()))
