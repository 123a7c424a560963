"""
A scripted USB host on the rehosted chip's OTG FS core (otg.py): the test's side of the cable.

It does what a PC's host controller and its enumeration do, one token at a time (USB 2.0,
chapters 8 and 9): wait for the device's pull-up, reset the bus, run control transfers
(SETUP, the data stage in 64-byte packets, the status stage) and read a bulk IN endpoint. A
token the device NAKs is sent again once the firmware has changed something the host waits for
(an endpoint enabled, a packet written): between two tries the chip runs. Every wait is bounded
in device time, and a device that does not answer raises UsbTimeout naming the stage and the
core's state, which is how far the stack got.
"""

from __future__ import annotations

import struct
import time

from .otg import ENDPOINTS

EP0_SIZE = 64
LINE_CODING = struct.pack('<IBBB', 921_600, 0, 0, 8)     # CDC PSTN 6.3.11: 8N1
RESET_RECOVERY_S = 0.010        # USB 2.0 7.1.7.3, TRSTRCY: the device may ignore the bus
DESCRIPTOR = {'device': 1, 'configuration': 2, 'string': 3, 'interface': 4, 'endpoint': 5}


class UsbTimeout(RuntimeError):
    """The device did not answer within the bound: the stage it stopped at, the core's state."""


def setup_packet(request_type: int, request: int, value: int, index: int, length: int) -> bytes:
    """Return the 8 bytes of a SETUP packet (USB 2.0 9.3)."""
    return struct.pack('<BBHHH', request_type, request, value, index, length)


def parse_descriptors(data: bytes) -> list:
    """Split a configuration descriptor set into (type, bytes) pairs; raise on a bad length."""
    out, k = [], 0
    while k < len(data):
        length = data[k]
        if length < 2 or k + length > len(data):
            raise ValueError(f'descriptor at byte {k} has length {length}')
        out.append((data[k + 1], bytes(data[k:k + length])))
        k += length
    return out


class ScriptedHost:
    """The host's side of the OTG FS core of chip, driving the chip between its tokens."""

    def __init__(self, chip, timeout_s: float = 0.2, wall_s: float = 60.0):
        """Attach to chip's OTG core; timeout_s bounds each wait in device time."""
        self.chip, self.otg = chip, chip.otg
        self.timeout_ns = int(timeout_s * 1e9)
        self.wall_s = wall_s
        self._changed = False
        self.otg.on_change = self._on_change
        self.transfers = 0

    def _on_change(self) -> None:
        self._changed = True
        self.chip.request_stop()

    def state(self) -> str:
        """Return the core's registers a stuck stage is read from."""
        o = self.otg
        eps = ', '.join(f'EP{n} IN ctl {o.inep[n].ctl:#x} tsiz {o.inep[n].tsiz:#x} '
                        f'OUT ctl {o.outep[n].ctl:#x} tsiz {o.outep[n].tsiz:#x}'
                        for n in range(ENDPOINTS) if o.inep[n].ctl or o.outep[n].ctl)
        return (f'GINTSTS {o.gintsts_now():#x} GINTMSK {o.regs[0x018]:#x} GAHBCFG '
                f'{o.gahbcfg:#x} DCFG {o.dcfg:#x} DCTL {o.dctl:#x} NVIC enabled '
                f'{self.chip.scb.enabled:#x}; {eps}; model errors {self.chip.errors}')

    def until(self, poll, what: str):
        """Run the chip until poll() returns something other than None; return it."""
        deadline = self.chip.now + self.timeout_ns
        wall = time.monotonic() + self.wall_s
        while True:
            got = poll()
            if got is not None:
                return got
            if self.chip.now >= deadline or time.monotonic() >= wall:
                raise UsbTimeout(f'{what}: no answer within {self.timeout_ns / 1e6:g} ms of '
                                 f'device time; {self.state()}')
            self._changed = False
            self.chip.run(until_s=deadline / 1e9, wall_s=max(wall - time.monotonic(), 0.01),
                          stop=lambda: self._changed)

    def run_for(self, seconds: float) -> None:
        """Let device time pass (the bus idle, or SOFs the device does not count)."""
        self.chip.run(until_s=self.chip.now / 1e9 + seconds, wall_s=self.wall_s)

    def attach(self) -> None:
        """Wait for the device's pull-up on D+ (the core connected and powered)."""
        self.until(lambda: True if self.otg.attached() is None else None,
                   'attach (D+ pull-up): ' + str(self.otg.attached()))

    def reset(self) -> None:
        """Reset the bus and give the device its reset recovery time."""
        self.otg.host_reset()
        self.run_for(RESET_RECOVERY_S)

    def control(self, setup: bytes, data_out: bytes = b'', what: str = 'control') -> bytes:
        """Run a control transfer on endpoint 0; return the data stage's bytes (IN)."""
        request_type, _, _, _, length = struct.unpack('<BBHHH', setup)
        self.otg.host_setup(setup)
        got = bytearray()
        if request_type & 0x80:
            while len(got) < length:
                packet = self.until(lambda: self.otg.host_in(0), f'{what}: IN data stage')
                got += packet
                if len(packet) < EP0_SIZE:
                    break
            self.until(lambda: True if self.otg.host_out(0, b'') else None,
                       f'{what}: OUT status stage')
        else:
            for k in range(0, len(data_out), EP0_SIZE):
                chunk = data_out[k:k + EP0_SIZE]
                self.until(lambda: True if self.otg.host_out(0, chunk) else None,
                           f'{what}: OUT data stage')
            status = self.until(lambda: self.otg.host_in(0), f'{what}: IN status stage')
            if status:
                raise ValueError(f'{what}: the status stage carried {len(status)} bytes')
        self.transfers += 1
        return bytes(got)

    def get_descriptor(self, kind: str, index: int = 0, length: int = 255,
                       langid: int = 0) -> bytes:
        """Return a descriptor (GET_DESCRIPTOR, USB 2.0 9.4.3)."""
        setup = setup_packet(0x80, 6, DESCRIPTOR[kind] << 8 | index, langid, length)
        return self.control(setup, what=f'GET_DESCRIPTOR({kind} {index})')

    def get_string(self, index: int, langid: int = 0x0409) -> str:
        """Return string descriptor index, decoded from UTF-16LE."""
        data = self.get_descriptor('string', index, 255, langid)
        if len(data) < 2 or data[1] != DESCRIPTOR['string'] or data[0] != len(data):
            raise ValueError(f'string {index}: not a string descriptor: {data.hex()}')
        return data[2:].decode('utf-16-le')

    def set_address(self, address: int) -> None:
        """SET_ADDRESS (9.4.6)."""
        self.control(setup_packet(0x00, 5, address, 0, 0), what=f'SET_ADDRESS({address})')

    def set_configuration(self, value: int) -> None:
        """SET_CONFIGURATION (9.4.7)."""
        self.control(setup_packet(0x00, 9, value, 0, 0), what=f'SET_CONFIGURATION({value})')

    def set_line_coding(self, coding: bytes = LINE_CODING) -> None:
        """CDC SET_LINE_CODING on interface 0 (PSTN 6.3.10), as a terminal program sends it."""
        self.control(setup_packet(0x21, 0x20, 0, 0, len(coding)), coding, 'SET_LINE_CODING')

    def set_lines(self, dtr: bool, rts: bool = True) -> None:
        """CDC SET_CONTROL_LINE_STATE (PSTN 6.3.12): DTR high is a program opening the port."""
        self.control(setup_packet(0x21, 0x22, int(dtr) | int(rts) << 1, 0, 0),
                     what=f'SET_CONTROL_LINE_STATE(DTR {int(dtr)})')

    def open_port(self, address: int) -> None:
        """Enumerate as a PC does, configure, and open the CDC port (line coding, DTR)."""
        self.attach()
        self.reset()
        self.set_address(address)
        self.set_configuration(1)
        self.set_line_coding()
        self.set_lines(True)

    def bulk_in(self, ep: int, sink, stop) -> int:
        """Read packets from IN endpoint ep into sink(bytes) until stop(); return the count."""
        packets = 0
        while not stop():
            sink(self.until(lambda: self.otg.host_in(ep), f'bulk IN on endpoint {ep}'))
            packets += 1
        return packets
