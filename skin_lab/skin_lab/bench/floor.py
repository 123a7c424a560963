"""
The rclpy floor of the end-to-end benchmark: the least an rclpy process does per scan.

It reads the port with one poll and one os.read, checks each frame's CRC-32, views its counts
with np.frombuffer (protocol version 1) or unpacks them (version 2), estimates them with the
estimator the nodes build from the same method, fills one reused TactileContactArray and
publishes it on ``contacts``. No parameters, services, diagnostics, executor, resynchronisation
counters or reconnects: the benchmark runs it beside the layouts, measured the same way, as the
reference for the driver's CPU per scan.

    python -m skin_lab.bench.floor PORT NAMESPACE METHOD ROWS COLS
"""

import os
import select
import struct
import sys
import time
import zlib

from builtin_interfaces.msg import Time
import numpy as np
import rclpy
import serial
from skin_driver.core.estimation.scan.pipeline import ContactEstimator, EstimatorConfig
from skin_driver.core.protocol.packed import body_layout, unpack_counts
from skin_driver.core.protocol.wire import CRC_SIZE, frame_size, HEADER_SIZE, SYNC
from skin_driver.ros import conversions, qos
from skin_driver.ros.spin import freeze_heap
from skin_msgs.msg import TactileContactArray
from std_msgs.msg import Header

_SEQ_AND_TIME = struct.Struct('<IQ')  # at byte 4 of a frame


def _open(port: str) -> serial.Serial:
    """Open the port once the board is there; pyserial configures it, the reads are ours."""
    while True:
        try:
            return serial.Serial(port)
        except serial.SerialException:  # the simulator starts after this process
            time.sleep(0.05)


def main(argv=None) -> int:
    """Publish the contacts of every scan read at PORT until interrupted."""
    port, namespace, method, rows, cols = (argv or sys.argv[1:])
    rows, cols = int(rows), int(cols)
    rclpy.init()
    node = rclpy.create_node('skin_floor', namespace=namespace)
    publisher = node.create_publisher(TactileContactArray, 'contacts', qos.stream())
    estimator = ContactEstimator(EstimatorConfig(method=method))
    writer = conversions.ContactArrayWriter()
    device = _open(port)
    poller = select.poll()
    poller.register(device.fileno(), select.POLLIN)
    sizes = {version: frame_size(rows, cols, version) for version in (1, 2)}
    count, packed_at = 2 * rows * cols, body_layout(rows, cols)[1]
    pending = b''
    freeze_heap()  # as the nodes do before they spin
    try:
        while rclpy.ok():
            if not poller.poll(50):
                continue
            pending += os.read(device.fileno(), 65536)
            sec, nanosec = divmod(time.time_ns(), 1_000_000_000)
            header = Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id='skin_link')
            while len(pending) > len(SYNC):
                start = pending.find(SYNC)
                if start != 0:
                    pending = pending[start:] if start > 0 else pending[-1:]
                    continue
                version = pending[len(SYNC)]
                size = sizes.get(version)
                if size is None:
                    pending = pending[len(SYNC):]
                    continue
                if len(pending) < size:
                    break
                if zlib.crc32(pending[:size - CRC_SIZE]) != int.from_bytes(
                        pending[size - CRC_SIZE:size], 'little'):
                    pending = pending[len(SYNC):]
                    continue
                seq, device_us = _SEQ_AND_TIME.unpack_from(pending, 4)
                counts = (np.frombuffer(pending, '<u2', count, HEADER_SIZE) if version == 1
                          else unpack_counts(pending, packed_at, count))
                top, bottom = counts.reshape(2, rows, cols)
                contacts = estimator.process(top, bottom)
                publisher.publish(writer.fill(header, contacts, seq, device_us))
                pending = pending[size:]
    except KeyboardInterrupt:
        pass
    finally:
        device.close()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
