"""The mock vehicle's side of MAVLink 2 signing, as ArduPilot does it.

* One table of stream timestamps per vehicle, shared by every peer (ArduPilot
  keeps one for all its channels): a signed frame captured on one connection
  and replayed on another is as old there as it was on the first.
* The signature is checked before its timestamp is believed, by the station's
  own check (``vehicles.signing.check_signature``, which says why), set up by the
  station's own ``vehicles.signing.sign_with``.
* Only radio status may come unsigned.
"""

from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.signing import sign_with

#: (link id, system id, component id) -> last accepted timestamp.
StreamTimestamps = dict[tuple[int, int, int], int]


def enable_signing(codec: mavlink.MAVLink, key: bytes, streams: StreamTimestamps) -> None:
    """Make ``codec`` sign what it sends and accept only frames signed with ``key``."""
    sign_with(codec, key, _allow_unsigned)
    codec.signing.stream_timestamps = streams


def _allow_unsigned(codec: mavlink.MAVLink, message_id: int) -> bool:
    """With signing on, only radio status may come unsigned (as on ArduPilot)."""
    return message_id in (mavlink.MAVLINK_MSG_ID_RADIO_STATUS, mavlink.MAVLINK_MSG_ID_RADIO)
