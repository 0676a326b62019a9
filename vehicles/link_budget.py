"""What a serial radio can carry, and telemetry rates that fit it.

A 57600 baud SiK radio moves at most 5760 bytes a second, less once its own
framing, error correction and the other direction take their share; the
station's usual streams cost a vehicle about 0.8 kB/s, the range readings it
asks for on each arrival come on top. A radio for the whole fleet
is therefore full at a handful of vehicles, and a full radio drops frames
everywhere, commands among them. ``fit_rates`` scales the rates down so that
the fleet's telemetry takes no more than ``share`` of the radio's bytes.
"""

from __future__ import annotations

from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

#: MAVLink 2 header (10 bytes) and checksum (2); a signature adds 13.
FRAME_OVERHEAD = 12
SIGNATURE = 13
#: Bits on the wire per byte on a serial line (8N1: start, 8 data, stop).
BITS_PER_BYTE = 10
#: The part of a radio the fleet's telemetry may take: the rest is for the radio's own
#: overhead, the station's commands and missions, and bursts.
TELEMETRY_SHARE = 0.5
#: Never slower than this, whatever the radio (the station needs to see a vehicle move).
MIN_RATE_HZ = 0.5


def frame_bytes(message_id: int, *, signed: bool = False) -> int:
    """Bytes of one MAVLink 2 frame of ``message_id`` (whole payload, as sent)."""
    payload = mavlink.mavlink_map[message_id].unpacker.size
    return FRAME_OVERHEAD + payload + (SIGNATURE if signed else 0)


def bytes_per_s(rates_hz: dict[int, float], *, signed: bool = False) -> float:
    """One vehicle's telemetry at ``rates_hz`` (message id -> Hz), with its heartbeat."""
    streams = sum(frame_bytes(m, signed=signed) * hz for m, hz in rates_hz.items() if hz > 0)
    return streams + frame_bytes(mavlink.MAVLINK_MSG_ID_HEARTBEAT, signed=signed)


@dataclass(frozen=True)
class LinkBudget:
    """How the fleet's telemetry fits a radio."""

    capacity_bytes_s: float
    needed_bytes_s: float
    #: The rates are multiplied by this (1: they fit as they are).
    factor: float

    def __str__(self) -> str:
        return (
            f"telemetry rates at {100 * self.factor:.0f} % of the usual to fit the radio "
            f"({self.needed_bytes_s * self.factor / 1000:.1f} kB/s of "
            f"{self.capacity_bytes_s / 1000:.1f})"
        )


def fit_rates(
    rates_hz: dict[int, float], *, baud: int, vehicles: int, signed: bool = False
) -> tuple[dict[int, float], LinkBudget]:
    """``rates_hz`` scaled so that ``vehicles`` of them take at most ``TELEMETRY_SHARE``
    of a serial line at ``baud`` (never below ``MIN_RATE_HZ``; a stream that is off stays
    off)."""
    capacity = baud / BITS_PER_BYTE
    needed = vehicles * bytes_per_s(rates_hz, signed=signed)
    factor = min(1.0, TELEMETRY_SHARE * capacity / needed) if needed > 0 else 1.0
    fitted = {
        m: hz if hz <= 0 or factor >= 1.0 else max(min(hz, MIN_RATE_HZ), hz * factor)
        for m, hz in rates_hz.items()
    }
    return fitted, LinkBudget(capacity, needed, factor)
