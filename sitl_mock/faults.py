"""Fault injection for one mock vehicle's link and protocols, all drawn from seeded randomness.

Link faults act on whole packets in each direction (loss, latency, a cut at
time t lasting d seconds). Mission protocol failures copy the failure modes
of QGroundControl's MockLink (a request never sent, the wrong sequence
number asked for, an error ACK, the final ACK lost). Command faults answer
commands with MAV_RESULT_FAILED or not at all. Battery noise and sags live
with the battery settings (``sitl_mock.battery``).
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field
from enum import Enum


@dataclass(frozen=True)
class LinkCut:
    """The link carries nothing from ``at_s`` for ``duration_s`` seconds (simulated time)."""

    at_s: float
    duration_s: float


@dataclass(frozen=True)
class LinkFaults:
    loss_to_gcs: float = 0.0
    loss_from_gcs: float = 0.0
    latency_s: float = 0.0
    #: Each packet waits a further U(0, jitter_s) seconds, so packets may overtake.
    jitter_s: float = 0.0
    cuts: tuple[LinkCut, ...] = ()

    def __post_init__(self) -> None:
        for name in ("loss_to_gcs", "loss_from_gcs"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {value}")
        if self.latency_s < 0 or self.jitter_s < 0:
            raise ValueError(
                f"latency and jitter must not be negative: {self.latency_s}, {self.jitter_s}"
            )

    def delay_s(self, rng: random.Random) -> float:
        """This packet's latency (simulated seconds)."""
        return self.latency_s + (rng.uniform(0.0, self.jitter_s) if self.jitter_s > 0 else 0.0)

    def cut_at(self, t_s: float) -> bool:
        return any(c.at_s <= t_s < c.at_s + c.duration_s for c in self.cuts)


class MissionFailure(Enum):
    """MockLink-style mission protocol failures (``at_seq`` picks the item concerned)."""

    NONE = "none"
    READ_LIST_NO_RESPONSE = "read_list_no_response"
    READ_ITEM_NO_RESPONSE = "read_item_no_response"
    READ_ITEM_WRONG_SEQUENCE = "read_item_wrong_sequence"
    READ_ITEM_ERROR_ACK = "read_item_error_ack"
    WRITE_COUNT_NO_RESPONSE = "write_count_no_response"
    WRITE_REQUEST_NO_RESPONSE = "write_request_no_response"
    WRITE_REQUEST_WRONG_SEQUENCE = "write_request_wrong_sequence"
    WRITE_REQUEST_ERROR_ACK = "write_request_error_ack"
    WRITE_FINAL_ACK_NO_RESPONSE = "write_final_ack_no_response"
    WRITE_FINAL_ACK_ERROR = "write_final_ack_error"


@dataclass(frozen=True)
class MissionFaults:
    failure: MissionFailure = MissionFailure.NONE
    at_seq: int = 0
    #: False: the failure happens once (so a retry succeeds); True: every time.
    repeat: bool = False


@dataclass(frozen=True)
class CommandFaults:
    fail_probability: float = 0.0
    ignore_probability: float = 0.0
    #: Only these MAV_CMD numbers are affected (None: every command).
    commands: frozenset[int] | None = None

    def affects(self, command: int) -> bool:
        return self.commands is None or command in self.commands


@dataclass(frozen=True)
class VehicleFaults:
    link: LinkFaults = field(default_factory=LinkFaults)
    mission: MissionFaults = field(default_factory=MissionFaults)
    commands: CommandFaults = field(default_factory=CommandFaults)


class MissionFaultTrigger:
    """Decides, once or every time, whether the configured mission failure fires now."""

    def __init__(self, faults: MissionFaults) -> None:
        self.faults = faults
        self._fired = False

    def fires(self, failure: MissionFailure, seq: int | None = None) -> bool:
        f = self.faults
        if f.failure is not failure or (seq is not None and seq != f.at_seq):
            return False
        if self._fired and not f.repeat:
            return False
        self._fired = True
        return True


class CommandVerdict(Enum):
    NORMAL = "normal"
    FAIL = "fail"
    IGNORE = "ignore"


class CommandFaultDice:
    def __init__(self, faults: CommandFaults, rng: random.Random) -> None:
        self.faults = faults
        self._rng = rng

    def roll(self, command: int) -> CommandVerdict:
        f = self.faults
        if not f.affects(command) or (f.fail_probability == 0 and f.ignore_probability == 0):
            return CommandVerdict.NORMAL
        x = self._rng.random()
        if x < f.ignore_probability:
            return CommandVerdict.IGNORE
        if x < f.ignore_probability + f.fail_probability:
            return CommandVerdict.FAIL
        return CommandVerdict.NORMAL
