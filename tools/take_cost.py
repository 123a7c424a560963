"""
CPU per message of subscriptions served on a thread of their own: private wait set or public.

Side by side in one process, in alternating rounds, the thread's CPU (time.thread_time) per
message received, messages published at a steady rate from another thread:

* private: skin_driver.ros.hot_path.TakenOnThread (rclpy's private wait set, its
  subscriptions and a guard condition alone; what the direction node and the probe use);
* public, own node: a SingleThreadedExecutor spinning a node that holds only the subscription
  (no parameter services), the public way to the same isolation;
* public, the node's executor: a SingleThreadedExecutor spinning a node with its parameter
  services, which is where the subscription would be served otherwise.

Run pinned to one core so that the rounds share it alike, e.g.
``taskset -c 1 tools/with-env.sh python tools/take_cost.py``. The figures are only as quiet as
the machine: state its load beside them.
"""

import argparse
import os
import threading
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from skin_driver.ros.hot_path import TakenOnThread
from skin_msgs.msg import SkinFrame

QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


class Received:
    """A callback counting messages; done once it has seen ``want``."""

    def __init__(self, want):
        """Count up to want messages."""
        self.want, self.count, self.done = want, 0, threading.Event()

    def __call__(self, _msg):
        """Count one message."""
        self.count += 1
        if self.count >= self.want:
            self.done.set()


def publish(node, topic, count, rate_hz, message):
    """Publish count messages at rate_hz (a steady schedule, not as fast as possible)."""
    pub = node.create_publisher(SkinFrame, topic, QOS)
    while pub.get_subscription_count() == 0:
        time.sleep(0.01)
    time.sleep(0.2)  # the subscription's matching completes on both sides
    start = time.monotonic()
    for i in range(count):
        delay = start + i / rate_hz - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        pub.publish(message)
    node.destroy_publisher(pub)


def private_round(topic, received):
    """Serve the subscription on TakenOnThread; return its thread's CPU seconds."""
    node = rclpy.create_node('take_cost_private', start_parameter_services=False)
    cpu, timed = timed_callback(received)
    taken = TakenOnThread(node, 'take-private')
    taken.subscribe(SkinFrame, topic, timed, QOS)
    taken.start()
    return node, taken.stop, cpu


def timed_callback(received):
    """Wrap received to read its thread's CPU at the first and the latest message."""
    cpu, first = {}, []

    def timed(msg):
        if not first:
            first.append(time.thread_time())
        received(msg)
        cpu['s'] = time.thread_time() - first[0]
    return cpu, timed


def executor_round(topic, received, services):
    """Serve the subscription with an executor on a thread; return its thread's CPU seconds."""
    node = rclpy.create_node('take_cost_public', start_parameter_services=services)
    cpu, timed = timed_callback(received)
    node.create_subscription(SkinFrame, topic, timed, QOS)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    thread = threading.Thread(target=executor.spin, daemon=True)
    thread.start()

    def stop():
        executor.shutdown(timeout_sec=2.0)
        thread.join(2.0)
    return node, stop, cpu


def main():
    """Print each way's thread CPU per message, round by round and their medians."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--messages', type=int, default=2000)
    parser.add_argument('--rate', type=float, default=1000.0, help='Hz')
    parser.add_argument('--rounds', type=int, default=3)
    args = parser.parse_args()
    rclpy.init()
    talker = rclpy.create_node('take_cost_talker', start_parameter_services=False)
    message = SkinFrame()
    ways = {'private wait set (TakenOnThread)': private_round,
            'public: executor, own node': lambda t, r: executor_round(t, r, False),
            "public: executor, node's services": lambda t, r: executor_round(t, r, True)}
    results = {name: [] for name in ways}
    for round_ in range(args.rounds):
        for i, (name, start) in enumerate(ways.items()):
            topic = f'take_cost_{round_}_{i}'
            received = Received(args.messages)
            node, stop, cpu = start(topic, received)
            publish(talker, topic, args.messages, args.rate, message)
            received.done.wait(30.0)
            stop()
            node.destroy_node()
            us = 1e6 * cpu.get('s', float('nan')) / max(received.count - 1, 1)
            results[name].append(us)
            print(f'round {round_ + 1}, {name}: {us:.1f} us per message '
                  f'({received.count} of {args.messages} received)', flush=True)
    print(f'cpus allowed {sorted(os.sched_getaffinity(0))}, load average {os.getloadavg()}')
    for name, values in results.items():
        print(f'median, {name}: {sorted(values)[len(values) // 2]:.1f} us per message')
    talker.destroy_node()
    rclpy.shutdown()


if __name__ == '__main__':
    main()
