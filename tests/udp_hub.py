"""A broadcast hub, as a radio is: every vehicle's datagram goes to the station, and
every station datagram to every vehicle, whoever it is for.

The vehicles send to ports of their own (``vehicle_ports``); the hub sends what they
say to ``station`` from one socket, so the station hears the whole fleet from one
address, and answers there. Frames are carried whole and unread.
"""

from __future__ import annotations

import select
import socket

from tests.relay import Relay

Address = tuple[str, int]


class UdpHub(Relay):
    def __init__(self, vehicles: int, station: Address) -> None:
        super().__init__("udp-hub")
        self.station = station
        self._vehicle_sockets = [_bound() for _ in range(vehicles)]
        self._station_socket = _bound()
        #: Where each vehicle socket last heard its vehicle from.
        self._vehicles: dict[socket.socket, Address] = {}
        self.to_station = 0
        self.to_vehicles = 0

    @property
    def vehicle_ports(self) -> list[int]:
        return [s.getsockname()[1] for s in self._vehicle_sockets]

    def close(self) -> None:
        for s in (*self._vehicle_sockets, self._station_socket):
            s.close()

    def relay_once(self) -> None:
        sockets = [*self._vehicle_sockets, self._station_socket]
        readable, _, _ = select.select(sockets, [], [], self.wait_s)
        for s in readable:
            try:
                data, sender = s.recvfrom(65536)
            except OSError:
                continue
            if s is self._station_socket:
                for vehicle_socket, vehicle in list(self._vehicles.items()):
                    self.to_vehicles += _send(vehicle_socket, data, vehicle)
            else:
                self._vehicles[s] = sender
                self.to_station += _send(self._station_socket, data, self.station)


def _bound() -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    return s


def _send(s: socket.socket, data: bytes, address: Address) -> int:
    try:
        s.sendto(data, address)
    except OSError:  # nobody listening there yet
        return 0
    return 1
