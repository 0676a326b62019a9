"""Telemetry rates that fit a serial radio (``vehicles.link_budget``)."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.live.mission import RATES_HZ, telemetry_rates
from gcs.live.run import LiveOptions
from gcs.mission import load_mission
from vehicles.link_budget import (
    MIN_RATE_HZ,
    TELEMETRY_SHARE,
    bytes_per_s,
    fit_rates,
    frame_bytes,
)


def test_frames_are_counted_as_they_travel() -> None:
    assert frame_bytes(mavlink.MAVLINK_MSG_ID_HEARTBEAT) == 12 + 9
    assert frame_bytes(mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, signed=True) == 12 + 28 + 13
    # The station's usual streams: about 0.8 kB/s a vehicle (the range replies asked for
    # on each arrival come on top).
    assert 600 < bytes_per_s(RATES_HZ) < 1000


def test_a_fleet_that_fits_keeps_its_rates() -> None:
    fitted, budget = fit_rates(RATES_HZ, baud=115200, vehicles=2)
    assert budget.factor == 1.0 and fitted == RATES_HZ


def test_five_vehicles_on_a_57600_radio_are_slowed_to_fit() -> None:
    fitted, budget = fit_rates(RATES_HZ, baud=57600, vehicles=5)
    assert 0.3 < budget.factor < 1.0
    assert 5 * bytes_per_s(fitted) <= TELEMETRY_SHARE * 5760 * 1.05  # the floors' slack
    assert fitted[mavlink.MAVLINK_MSG_ID_ATTITUDE] == 0.0  # off stays off
    assert "telemetry rates at" in str(budget) and "of 5.8" in str(budget)


@given(
    baud=st.sampled_from([9600, 19200, 57600, 115200, 921600]),
    vehicles=st.integers(1, 64),
    signed=st.booleans(),
)
def test_fitted_rates_never_rise_and_never_stop_a_stream(
    baud: int, vehicles: int, signed: bool
) -> None:
    fitted, budget = fit_rates(RATES_HZ, baud=baud, vehicles=vehicles, signed=signed)
    assert 0.0 < budget.factor <= 1.0
    for message_id, hz in RATES_HZ.items():
        assert fitted[message_id] <= hz
        if hz > 0:
            assert fitted[message_id] >= min(hz, MIN_RATE_HZ)
        else:
            assert fitted[message_id] == hz


@pytest.mark.parametrize("vehicles", [1, 5, 16])
def test_the_budget_grows_with_the_fleet(vehicles: int) -> None:
    _, budget = fit_rates(RATES_HZ, baud=57600, vehicles=vehicles)
    assert budget.needed_bytes_s == pytest.approx(vehicles * bytes_per_s(RATES_HZ))


def test_the_fleet_on_one_radio_is_counted_however_the_device_is_spelt(tmp_path: Path) -> None:
    (tmp_path / "m.txt").write_text("C....\n.....\n")
    spellings = ["serial:/dev/ttyUSB0:57600", "/dev/ttyUSB0,57600", "serial:///dev/ttyUSB0:57600"]
    vehicles = [{"connection": spellings[i % 3]} for i in range(5)]
    vehicles.append({"connection": "udpin:127.0.0.1:14550"})
    text = "map: m.txt\nfleet:\n  vehicles:\n" + "".join(
        f"    - {{connection: '{v['connection']}'}}\n" for v in vehicles
    )
    (tmp_path / "m.yaml").write_text(text)
    notices: list[str] = []
    rates = telemetry_rates(load_mission(tmp_path / "m.yaml"), LiveOptions(), notices.append)
    assert notices == [
        "serial:/dev/ttyUSB0:57600: 5 vehicle(s) on one radio: telemetry rates at 76 % of "
        "the usual to fit the radio (2.9 kB/s of 5.8)"
    ]
    assert all(rates[sysid] != RATES_HZ for sysid in range(1, 6))
    assert rates[6] == RATES_HZ  # the UDP vehicle keeps its rates
