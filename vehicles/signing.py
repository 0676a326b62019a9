"""MAVLink 2 message signing: one 32-byte secret key per vehicle.

We sign everything we send once a key is set. Incoming messages must be
signed with the same key when ``require_signed`` is true; otherwise unsigned
messages are accepted too (but a message signed with a wrong key never is).
A signed message is also refused when its timestamp is not newer than the
last one of its stream (link id, system, component): a replay. The signature
is checked before the timestamp is believed (pymavlink's own check does it the
other way round, so one forged frame stamped far ahead would make every later
genuine frame of its stream look like a replay).
"""

from __future__ import annotations

import functools
import hashlib
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mavlink

KEY_LEN = 32
#: Signing timestamps count 10 µs ticks since 2015-01-01 00:00:00 UTC.
_SIGNING_EPOCH_UNIX_S = 1_420_070_400
#: A stream not seen before may start at most one minute (in 10 µs ticks) behind us.
_NEW_STREAM_SLACK = 6_000_000


@dataclass(frozen=True)
class SigningConfig:
    key: bytes = field(repr=False)  # a secret: never in a log line
    link_id: int = 0
    require_signed: bool = False

    def __post_init__(self) -> None:
        if len(self.key) != KEY_LEN:
            raise ValueError(f"signing key must be {KEY_LEN} bytes, got {len(self.key)}")
        if not 0 <= self.link_id <= 255:
            raise ValueError(f"link_id must be 0..255, got {self.link_id}")

    @classmethod
    def from_passphrase(cls, passphrase: str, **kwargs: object) -> SigningConfig:
        """The key MAVProxy's ``signing setup PASSPHRASE`` derives (SHA-256 of it)."""
        return cls(key=hashlib.sha256(passphrase.encode()).digest(), **kwargs)  # type: ignore[arg-type]

    @classmethod
    def from_hex(cls, text: str, **kwargs: object) -> SigningConfig:
        return cls(key=bytes.fromhex(text), **kwargs)  # type: ignore[arg-type]


def signing_timestamp(unix_s: float | None = None) -> int:
    """A signing timestamp for ``unix_s`` (now by default)."""
    t = time.time() if unix_s is None else unix_s
    return max(0, int((t - _SIGNING_EPOCH_UNIX_S) * 100_000))


def _accept_unsigned(codec: mavlink.MAVLink, _msg_id: int) -> bool:
    """Accept a message without a signature, never one whose signature failed.

    pymavlink asks this callback in both cases; it counts a failed signature in
    ``badsig_count`` just before asking, which tells the two apart."""
    seen = getattr(codec, "_badsig_seen", 0)
    codec._badsig_seen = codec.signing.badsig_count  # type: ignore[attr-defined]
    return codec.signing.badsig_count == seen


def apply_signing(codec: mavlink.MAVLink, config: SigningConfig | None) -> None:
    """Configure ``codec`` to sign with ``config`` (or to stop signing when ``None``)."""
    if config is None:
        codec.signing.secret_key = None
        codec.signing.sign_outgoing = False
        codec.signing.allow_unsigned_callback = None
        return
    codec.signing.link_id = config.link_id
    sign_with(codec, config.key, None if config.require_signed else _accept_unsigned)


def sign_with(
    codec: mavlink.MAVLink,
    key: bytes,
    allow_unsigned: Callable[[mavlink.MAVLink, int], bool] | None,
) -> None:
    """Make ``codec`` sign what it sends with ``key`` and check what it receives with
    ``check_signature``; ``allow_unsigned`` says which unsigned messages pass (none when
    ``None``). The station's links and the mock vehicles both start signing here."""
    codec.signing.secret_key = key
    codec.signing.sign_outgoing = True
    codec.signing.timestamp = max(codec.signing.timestamp, signing_timestamp())
    codec.signing.allow_unsigned_callback = allow_unsigned
    # pymavlink calls ``self.check_signature(...)``: an instance attribute replaces it.
    codec.check_signature = functools.partial(check_signature, codec)  # type: ignore[method-assign]


def check_signature(
    codec: mavlink.MAVLink, msgbuf: bytearray, src_system: int, src_component: int
) -> bool:
    """True when ``msgbuf`` carries a good signature newer than its stream's last one
    (the station's links and the mock vehicles both check with this)."""
    signing = codec.signing
    digest = hashlib.sha256(signing.secret_key + bytes(msgbuf[:-6])).digest()[:6]
    if digest != bytes(msgbuf[-6:]):
        return False
    tlow, thigh = codec.mav_sign_unpacker.unpack(msgbuf[-12:-6])
    timestamp = tlow + (thigh << 32)
    stream = (msgbuf[-13], src_system, src_component)
    last = signing.stream_timestamps.get(stream)
    if last is not None and timestamp <= last:
        return False  # a replay
    if last is None and timestamp + _NEW_STREAM_SLACK < signing.timestamp:
        return False  # a new stream that starts in the past
    signing.stream_timestamps[stream] = timestamp
    signing.timestamp = max(signing.timestamp, timestamp)
    return True
