"""MAVLink 2 frames, good and bad, built byte by byte for the garbage and fuzz tests.

Each builder gives the exact bytes that go on the wire, so a test knows which
counter each datagram must move: one bad frame per run of garbage bytes, per
truncated frame or per bad CRC; one unknown message per frame of an id the
dialect does not know; one foreign frame per good frame of another system.
"""

from __future__ import annotations

import random
import struct

from pymavlink.dialects.v20 import ardupilotmega as mavlink

STX = frozenset((mavlink.PROTOCOL_MARKER_V1, mavlink.PROTOCOL_MARKER_V2))
#: Every byte value that cannot start a frame.
NOT_STX = bytes(b for b in range(256) if b not in STX)
GCS_SYSTEM = 255
GCS_COMPONENT = mavlink.MAV_COMP_ID_MISSIONPLANNER
VEHICLE_COMPONENT = mavlink.MAV_COMP_ID_AUTOPILOT1
#: A message id the dialect does not know (its CRC extra unknown, so nobody checks its CRC).
UNKNOWN_MSG_ID = max(mavlink.mavlink_map) + 1
#: The longest MAVLink 2 frame: header, 255 payload bytes, CRC, signature.
MAX_FRAME_LEN = mavlink.HEADER_LEN_V2 + 255 + 2 + mavlink.MAVLINK_SIGNATURE_BLOCK_LEN
_V2_HEADER = struct.Struct("<BBBBBBBHB")


def pack(msg: mavlink.MAVLink_message, sysid: int, compid: int) -> bytes:
    """``msg`` as one frame from ``sysid``/``compid``. The sequence number is chosen,
    where one can be, so that no byte after the first is a start marker (``clean``)."""
    codec = mavlink.MAVLink(None, sysid, compid)
    first = b""
    for seq in range(256):
        codec.seq = seq
        frame = bytes(msg.pack(codec))
        if clean(frame):
            return frame
        first = first or frame
    return first  # the header itself has a marker byte (STATUSTEXT's id is 253)


def clean(frame: bytes) -> bool:
    """No start marker after the first byte: a parser that lost its way in a stream of
    such frames finds the next frame's start and nothing else."""
    return not STX.intersection(frame[1:])


def vehicle_heartbeat(sysid: int) -> bytes:
    """A rover's HEARTBEAT, as an ArduPilot vehicle ``sysid`` sends it."""
    msg = mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_GROUND_ROVER,
        mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
        mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
        0,
        mavlink.MAV_STATE_STANDBY,
        3,
    )
    return pack(msg, sysid, VEHICLE_COMPONENT)


def statustext(sysid: int, text: str) -> bytes:
    msg = mavlink.MAVLink_statustext_message(mavlink.MAV_SEVERITY_INFO, text.encode(), 0, 0)
    return pack(msg, sysid, VEHICLE_COMPONENT)


def gcs_command(target_system: int, command: int, *params: float) -> bytes:
    """A ground station's COMMAND_LONG to ``target_system``'s autopilot."""
    padded = [*params, *[0.0] * (7 - len(params))]
    msg = mavlink.MAVLink_command_long_message(
        target_system, VEHICLE_COMPONENT, command, 0, *padded
    )
    return pack(msg, GCS_SYSTEM, GCS_COMPONENT)


def bad_crc(frame: bytes) -> bytes:
    """``frame`` with its checksum inverted."""
    return frame[:-2] + bytes(b ^ 0xFF for b in frame[-2:])


def truncated(frame: bytes, keep: int) -> bytes:
    """The first ``keep`` bytes of ``frame`` (0 < keep < len(frame))."""
    assert 0 < keep < len(frame)
    return frame[:keep]


def unknown_id_frame(sysid: int, payload: bytes = b"\x01\x02\x03") -> bytes:
    """A well-formed frame of a message id the dialect does not know."""
    header = _V2_HEADER.pack(
        mavlink.PROTOCOL_MARKER_V2,
        len(payload),
        0,
        0,
        0,
        sysid,
        VEHICLE_COMPONENT,
        UNKNOWN_MSG_ID & 0xFFFF,
        UNKNOWN_MSG_ID >> 16,
    )
    return header + payload + bytes(2)


def with_payload(msg_id: int, payload: bytes, sysid: int, compid: int) -> bytes:
    """A frame of a known message with any payload bytes and a good CRC: it passes
    every check of the parser and carries nonsense (NaNs, invalid text, odd enums)."""
    assert len(payload) <= 255
    header = _V2_HEADER.pack(
        mavlink.PROTOCOL_MARKER_V2,
        len(payload),
        0,
        0,
        0,
        sysid,
        compid,
        msg_id & 0xFFFF,
        msg_id >> 16,
    )
    crc = mavlink.x25crc(header[1:] + payload)
    crc.accumulate(bytes([mavlink.mavlink_map[msg_id].crc_extra]))
    return header + payload + struct.pack("<H", crc.crc)


def garbage(rng: random.Random, size: int) -> bytes:
    """``size`` random bytes with no start marker among them: exactly one bad frame."""
    return bytes(rng.choice(NOT_STX) for _ in range(size))
