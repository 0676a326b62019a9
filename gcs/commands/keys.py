"""``--keys FILE``: the one signing option of every command (the format: README, Signing).

A key file names a key per system id. ``gcs run`` and ``sitl-mock`` give each
vehicle its own; ``gcs status`` and ``gcs mission`` talk over one connection,
which carries one key, so they need the key of the vehicle they address.
"""

from __future__ import annotations

import sys
from collections.abc import Iterable
from pathlib import Path

from gcs.errors import UsageError
from vehicles.keyfile import KeyFile, KeyFileError, load_key_file, loose_permissions
from vehicles.signing import SigningConfig


def load_keys(path: Path, prog: str, fleet: Iterable[int] | None = None) -> KeyFile:
    """The key file at ``path``; a usage error if it cannot be used (or, given the
    ``fleet``'s system ids, names a vehicle outside it), a warning on stderr, after
    ``prog`` ("gcs run", "sitl-mock"), when others than its owner may read it."""
    try:
        keys = load_key_file(path)
        if fleet is not None:
            keys.check_fleet(fleet)
    except KeyFileError as exc:
        raise UsageError(str(exc)) from exc
    warning = loose_permissions(path)
    if warning is not None:
        print(f"{prog}: warning: {warning}", file=sys.stderr)
    return keys


def connection_signing(keys: KeyFile, sysid: int | None) -> SigningConfig:
    """The signing of one connection: vehicle ``sysid``'s key, or with no ``sysid`` the
    file's only key (the same key for every vehicle counts as one)."""
    if sysid is not None:
        config = keys.signing(sysid)
        if config is None:
            raise UsageError(f"{keys.source}: no key for system {sysid}")
        return config
    distinct = {keys.keys[s] for s in keys.sysids}
    if len(distinct) > 1:
        systems = ", ".join(str(s) for s in sorted(keys.sysids))
        raise UsageError(
            f"{keys.source}: different keys for systems {systems}; one connection carries one "
            "key: name the vehicle with --sysid, or give a file with that vehicle's key"
        )
    config = keys.signing(min(keys.sysids))
    assert config is not None  # a key file holds at least one key
    return config
