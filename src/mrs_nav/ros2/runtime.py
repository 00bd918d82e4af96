"""An rclpy node spun in a thread and torn down in the order rclpy needs."""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator

import rclpy
from rclpy.executors import Executor, MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions


def _spin_until(executor: Executor, stop: threading.Event) -> None:
    while not stop.is_set():
        executor.spin_once(timeout_sec=0.1)


@contextlib.contextmanager
def spinning_node(name: str, namespace: str = "", threads: int = 1) -> Iterator[Node]:
    """A node whose callbacks run in a thread of their own for the block (in ``threads`` threads if more than
    one: callbacks that wait, as an action's execution does, then leave the others running).

    rclpy installs no signal handlers (the process ends at the end of its input, or as its parent says), and the
    end goes in order: the spinning stops, then the executor, the node and the context go (tearing rclpy down
    under a spinning executor raises in its thread or aborts the process)."""
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = Node(name, namespace="/" + namespace.strip("/"))
    executor = SingleThreadedExecutor() if threads == 1 else MultiThreadedExecutor(num_threads=threads)
    executor.add_node(node)
    stop = threading.Event()
    spinner = threading.Thread(target=_spin_until, args=(executor, stop), daemon=True)
    spinner.start()
    try:
        yield node
    finally:
        stop.set()
        spinner.join()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
