"""Signing key files: one MAVLink 2 secret key per vehicle, kept out of the mission file.

A key file is YAML with one mapping, ``vehicles``, from system id to key::

    # keys.yaml (chmod 600 keys.yaml)
    vehicles:
      1: "9f86d081884c7d659a2feaa0c55ad015a3bf4f1b2b0b822cd15d6c15b0f00a08"
      2: "passphrase:correct horse battery staple"

A key is 64 hex digits (32 bytes), or ``passphrase:TEXT``: the SHA-256 of
TEXT, the key MAVProxy's ``signing setup TEXT`` derives. Quote the keys: YAML
reads a key of decimal digits only as a number. Every problem raises
:class:`KeyFileError`, one line naming the file and the vehicle but never
showing a key.
"""

from __future__ import annotations

import hashlib
import re
import stat
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import yaml

from vehicles.signing import KEY_LEN, SigningConfig

PASSPHRASE_PREFIX = "passphrase:"
MAX_SYSID = 255
_HEX_KEY = re.compile(r"[0-9a-fA-F]{64}")
_FORMS = f"{2 * KEY_LEN} hex digits or '{PASSPHRASE_PREFIX}...'"


class KeyFileError(ValueError):
    """A key file that cannot be used; ``str()`` is one line: ``"<file>: <key>: <problem>"``."""

    def __init__(self, source: str, key: str | None, problem: str) -> None:
        super().__init__(f"{source}: {key}: {problem}" if key else f"{source}: {problem}")
        self.source = source
        self.key = key
        self.problem = problem


@dataclass(frozen=True)
class KeyFile:
    """The signing keys of a fleet, by system id. Its ``repr`` shows no key."""

    source: str
    keys: Mapping[int, bytes] = field(repr=False, hash=False)

    @property
    def sysids(self) -> frozenset[int]:
        return frozenset(self.keys)

    def signing(self, sysid: int, *, link_id: int = 0) -> SigningConfig | None:
        """Signing for vehicle ``sysid`` (signed both ways, unsigned refused); None: no key."""
        key = self.keys.get(sysid)
        return None if key is None else SigningConfig(key, link_id, require_signed=True)

    def check_fleet(self, sysids: Iterable[int]) -> None:
        """Raise :class:`KeyFileError` for a key of a vehicle that is not in ``sysids``."""
        fleet = set(sysids)
        for sysid in sorted(self.keys):
            if sysid not in fleet:
                raise KeyFileError(
                    self.source, f"vehicles.{sysid}", f"no vehicle {sysid} in the fleet"
                )


def load_key_file(path: str | Path) -> KeyFile:
    """Read and validate a key file; raise :class:`KeyFileError` on any problem."""
    path = Path(path)
    source = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise KeyFileError(source, None, "not a text file (not valid UTF-8)") from None
    except OSError as exc:
        raise KeyFileError(source, None, f"cannot read file: {exc.strerror or exc}") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = "" if mark is None else f" at line {mark.line + 1}, column {mark.column + 1}"
        raise KeyFileError(source, None, f"invalid YAML{where}") from None
    if data is None:
        raise KeyFileError(source, None, "file is empty (a key file needs 'vehicles')")
    if not isinstance(data, dict):
        raise KeyFileError(
            source, None, f"top level must be a mapping with 'vehicles', got {_kind(data)}"
        )
    for name in data:
        if name != "vehicles":
            raise KeyFileError(source, None, f"unknown key {name!r} (a key file has 'vehicles')")
    if "vehicles" not in data:
        raise KeyFileError(source, "vehicles", "missing (a mapping of system id to key)")
    vehicles = data["vehicles"]
    if not isinstance(vehicles, dict):
        raise KeyFileError(
            source, "vehicles", f"must be a mapping of system id to key, got {_kind(vehicles)}"
        )
    if not vehicles:
        raise KeyFileError(source, "vehicles", "no vehicle has a key")
    keys: dict[int, bytes] = {}
    for name, value in vehicles.items():
        sysid = _sysid(source, name)
        if sysid in keys:
            raise KeyFileError(source, f"vehicles.{sysid}", "given twice")
        keys[sysid] = _key(source, f"vehicles.{sysid}", value)
    return KeyFile(source, MappingProxyType(keys))


def loose_permissions(path: str | Path) -> str | None:
    """A one-line warning when others than the owner may open ``path`` (as ssh warns)."""
    try:
        mode = stat.S_IMODE(Path(path).stat().st_mode)
    except OSError:
        return None
    if not mode & 0o077:
        return None
    return f"{path}: open to group or others (mode {mode:04o}); chmod 600 {path}"


def _sysid(source: str, name: Any) -> int:
    if isinstance(name, str) and name.strip().isdigit():
        name = int(name)
    if isinstance(name, bool) or not isinstance(name, int):
        raise KeyFileError(
            source, f"vehicles.{name}", f"not a system id (an integer 1..{MAX_SYSID})"
        )
    if not 1 <= name <= MAX_SYSID:
        raise KeyFileError(source, f"vehicles.{name}", f"system id out of range 1..{MAX_SYSID}")
    return name


def _key(source: str, where: str, value: Any) -> bytes:
    if not isinstance(value, str):
        hint = " (quote it)" if isinstance(value, int | float) else ""
        raise KeyFileError(source, where, f"must be a string, {_FORMS}; got {_kind(value)}{hint}")
    if value.startswith(PASSPHRASE_PREFIX):
        passphrase = value[len(PASSPHRASE_PREFIX) :]
        if not passphrase:
            raise KeyFileError(source, where, "empty passphrase")
        return hashlib.sha256(passphrase.encode("utf-8")).digest()
    if not _HEX_KEY.fullmatch(value):
        if len(value) != 2 * KEY_LEN:
            got = f"{len(value)} characters"
        else:
            got = "characters that are not hex digits"
        raise KeyFileError(source, where, f"must be {_FORMS}; got {got}")
    key = bytes.fromhex(value)
    if not any(key):
        raise KeyFileError(source, where, "an all-zero key means 'no signing' to ArduPilot")
    return key


def _kind(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, int | float):
        return "a number"
    return type(value).__name__
