"""The ground-station failsafe of a mock vehicle: what it does when its GCS falls silent.

Modelled on ArduPilot (Copter ``FS_GCS_ENABLE``, ``FS_GCS_TIMEOUT``,
``FS_OPTIONS``; Rover ``FS_GCS_ENABLE`` and ``FS_ACTION``):

* The failsafe is armed only once a ground station has been heard: a
  HEARTBEAT of type MAV_TYPE_GCS (the endpoint passes it on as
  ``Vehicle.gcs_heartbeat``). ArduPilot counts only the heartbeats of its
  ``MAV_GCS_SYSID`` (255); the mock counts every ground station's.
* It triggers when no GCS heartbeat has come for ``timeout_s`` of vehicle time
  while the vehicle is armed, and announces it with STATUSTEXT "GCS Failsafe"
  (ArduPilot Copter also announces it disarmed, without acting; the mock stays
  quiet then). A rover already in HOLD or RTL is left alone, as on ArduPilot Rover.
* The action: ``HOLD`` stops where the vehicle is (Rover HOLD; Copter BRAKE, as
  ArduPilot's "Brake or Land"), ``RTL`` returns to launch (a copter lands there
  and disarms; a rover drives there and stops); ``NONE`` turns the failsafe off
  (ArduPilot's default). A copter still on the ground disarms instead; a copter
  landing goes on landing.
  With ``continue_auto`` a vehicle flying a mission in AUTO carries on
  (ArduPilot's FS_OPTIONS bit "continue if in auto"); this is the default
  because our ground station flies the way home as an AUTO mission precisely
  so that it gets home without the link.
* When a GCS heartbeat comes back the failsafe clears ("GCS Failsafe Cleared");
  the mode is not changed back: the ground station decides what comes next,
  and may set GUIDED, arm and send targets at once.

The mock moves in straight lines and stops at a wall ("Move refused"): an RTL
across walls stops at the first one and holds there, as a real RTL, which
also flies straight home, would hit it.

Time is vehicle time (``Vehicle.elapsed_s``), so under a sped-up clock the
ground station must send its heartbeats at 1 Hz of vehicle time, as it must
for an ArduPilot SITL run with a speed-up.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum


class FailsafeAction(StrEnum):
    """What the vehicle does on ground-station loss."""

    NONE = "none"
    HOLD = "hold"
    RTL = "rtl"


@dataclass(frozen=True)
class GcsFailsafe:
    """The GCS failsafe settings. The default is ArduPilot's as shipped: off
    (FS_GCS_ENABLE 0); ``sitl-mock`` fleets hold (see ``gcs.sitl_cli``)."""

    action: FailsafeAction = FailsafeAction.NONE
    #: Seconds of vehicle time without a GCS heartbeat (ArduPilot FS_GCS_TIMEOUT, default 5).
    timeout_s: float = 5.0
    #: A vehicle flying a mission in AUTO carries on with it.
    continue_auto: bool = True

    def __post_init__(self) -> None:
        if not self.timeout_s > 0:
            raise ValueError(f"timeout_s must be positive, got {self.timeout_s}")

    @property
    def enabled(self) -> bool:
        return self.action is not FailsafeAction.NONE


class GcsWatch:
    """When a ground station was last heard, and whether the failsafe is on."""

    def __init__(self, settings: GcsFailsafe) -> None:
        self.settings = settings
        #: Vehicle time of the last GCS heartbeat; None until the first.
        self.last_heard_s: float | None = None
        self.active = False

    def heard(self, now_s: float) -> bool:
        """A GCS heartbeat at ``now_s``; True if it clears an active failsafe."""
        self.last_heard_s = now_s
        cleared, self.active = self.active, False
        return cleared

    def overdue(self, now_s: float) -> bool:
        """Enabled, a GCS was heard once, and not for longer than the timeout."""
        return (
            self.settings.enabled
            and self.last_heard_s is not None
            and now_s - self.last_heard_s > self.settings.timeout_s
        )
