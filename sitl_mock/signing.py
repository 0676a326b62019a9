"""The mock vehicle's side of MAVLink 2 signing, as ArduPilot does it.

* One table of stream timestamps per vehicle, shared by every peer (ArduPilot
  keeps one for all its channels): a signed frame captured on one connection
  and replayed on another is as old there as it was on the first.
* The signature is checked before its timestamp is believed. pymavlink's own
  check records a frame's timestamp before it compares the signature, so one
  forged frame with a timestamp far ahead would make every later genuine frame
  of that stream look like a replay.
* Only radio status may come unsigned.
"""

from __future__ import annotations

import functools
import hashlib
import time

from pymavlink.dialects.v20 import ardupilotmega as mavlink

#: Seconds from the Unix epoch to the MAVLink signing epoch (2015-01-01).
SIGNING_EPOCH_S = 1_420_070_400
#: A stream not seen before may start at most this far (10 µs ticks, one minute)
#: behind our own timestamp, as in pymavlink and the C library.
NEW_STREAM_SLACK = 6_000_000

#: (link id, system id, component id) -> last accepted timestamp.
StreamTimestamps = dict[tuple[int, int, int], int]


def enable_signing(codec: mavlink.MAVLink, key: bytes, streams: StreamTimestamps) -> None:
    """Make ``codec`` sign what it sends and accept only frames signed with ``key``."""
    codec.signing.secret_key = key
    codec.signing.sign_outgoing = True
    codec.signing.timestamp = max(
        codec.signing.timestamp, int((time.time() - SIGNING_EPOCH_S) * 100_000)
    )
    codec.signing.allow_unsigned_callback = _allow_unsigned
    codec.signing.stream_timestamps = streams
    # pymavlink calls ``self.check_signature(...)``: an instance attribute replaces it.
    codec.check_signature = functools.partial(check_signature, codec)  # type: ignore[method-assign]


def check_signature(
    codec: mavlink.MAVLink, msgbuf: bytearray, src_system: int, src_component: int
) -> bool:
    """True when ``msgbuf`` carries a good signature newer than its stream's last one."""
    signing = codec.signing
    digest = hashlib.sha256(signing.secret_key + bytes(msgbuf[:-6])).digest()[:6]
    if digest != bytes(msgbuf[-6:]):
        return False
    tlow, thigh = codec.mav_sign_unpacker.unpack(msgbuf[-12:-6])
    timestamp = tlow + (thigh << 32)
    stream = (msgbuf[-13], src_system, src_component)
    last = signing.stream_timestamps.get(stream)
    if last is not None and timestamp <= last:
        return False  # a replay, or older than what we already took
    if last is None and timestamp + NEW_STREAM_SLACK < signing.timestamp:
        return False  # a new stream that starts in the past
    signing.stream_timestamps[stream] = timestamp
    signing.timestamp = max(signing.timestamp, timestamp)
    return True


def _allow_unsigned(codec: mavlink.MAVLink, message_id: int) -> bool:
    """With signing on, only radio status may come unsigned (as on ArduPilot)."""
    return message_id in (mavlink.MAVLINK_MSG_ID_RADIO_STATUS, mavlink.MAVLINK_MSG_ID_RADIO)
