"""The node's ``markers`` off its control path: :class:`MarkerPublisher`.

The node's thread only keeps the latest answered solution (:meth:`MarkerPublisher.offer`).
A thread of the publisher, at the rate, hands a :class:`~.markers.Snapshot` of
it to a renderer process (``python -P -m flight_sim_dynamics.ros.marker_publisher``:
:class:`~.markers.MarkerBuilder` and rclpy's serialization, the work that holds
the interpreter lock for a tenth of a millisecond per array) and publishes the
serialized array it gets back. In the node's process a tick holds the lock for
the snapshot's pickle and the raw publish only (docs/node.md, "Markers"). A
tick with no subscription to ``markers`` draws nothing; the renderer starts at
the first one that has a subscriber.
"""
from __future__ import annotations

import copyreg
import math
import os
import pickle
import signal
import struct
import subprocess
import sys
import threading
import time
import types
from typing import Any

from rclpy.serialization import serialize_message
from visualization_msgs.msg import MarkerArray

from ..core.machine import Machine
from ..machines.api import machine_of
from .markers import MarkerBuilder, Snapshot, clear_array, snapshot
from .process import node_env, python_module

LOG_THROTTLE = 5.0       # s between two log lines of failed markers
JOIN_TIMEOUT = 2.0       # s for the renderer to end at close
_FRAME = struct.Struct('<I')     # length prefix of a message on the pipes


def _mapping_proxy(items: dict) -> types.MappingProxyType:
    return types.MappingProxyType(items)


# models keep read-only mappings (a model is sent to the renderer pickled)
copyreg.pickle(types.MappingProxyType, lambda p: (_mapping_proxy, (dict(p),)))


def _write(fd: int, data: bytes) -> None:
    view = memoryview(_FRAME.pack(len(data)) + data)
    while view:
        view = view[os.write(fd, view):]


def _read(fd: int) -> bytes | None:
    """One message, None at the end of the pipe."""
    head = _read_exactly(fd, _FRAME.size)
    return None if head is None else _read_exactly(fd, _FRAME.unpack(head)[0])


def _read_exactly(fd: int, n: int) -> bytes | None:
    chunks, left = [], n
    while left:
        chunk = os.read(fd, left)
        if not chunk:
            return None
        chunks.append(chunk)
        left -= len(chunk)
    return b''.join(chunks)


class MarkerPublisher:
    """``markers`` (MarkerArray, depth 10; a lifecycle publisher on a lifecycle
    node) of ``machine``'s ``model`` in ``frame_id`` at ``rate`` Hz (0: none):
    the latest offered solution stamped like its setpoint; before any, the home
    pose stamped with the node's clock. Nothing it does raises into the node:
    a failure is logged (at most every :data:`LOG_THROTTLE` s) and the next tick
    tries again.
    """

    def __init__(self, node: Any, machine: Machine, model: Any, frame_id: str,
                 rate: float) -> None:
        self._node = node
        self._machine = machine
        create = getattr(node, 'create_lifecycle_publisher', node.create_publisher)
        self._pub = create(MarkerArray, 'markers', 10)
        self._model, self._frame, self._rate = model, frame_id, float(rate)
        self._latest: tuple[tuple[int, int], Any] | None = None
        self._stamp = (0, 0)                # of the last array published
        self._sent_model: Any = None        # the renderer's model
        self._generation = 0                # a clear or close drops the tick under way
        self._lock = threading.Lock()       # publishing, against clear and close
        self._wake = threading.Event()
        self._due = math.inf                # monotonic time of the next array
        self._kicked = False                # woken by an offer for it
        self._closed = False
        # started at the first array someone subscribes to: a node nobody views
        # draws nothing and starts no process
        self._child: subprocess.Popen | None = None
        self._thread = threading.Thread(target=self._run, name='markers', daemon=True)
        self._thread.start()

    # -- the node's calls (its thread) -------------------------------------------------
    def offer(self, header: tuple[int, int], solution: Any) -> None:
        """The latest answered setpoint's stamp (sec, nanosec) and solution: kept;
        when an array is due, the thread is woken to draw it now, while the node
        waits for its next setpoint.
        """
        self._latest = (header, solution)
        if not self._kicked and time.monotonic() >= self._due:
            self._kicked = True
            self._wake.set()

    def set_model(self, model: Any) -> None:
        self._model = model

    def set_frame(self, frame_id: str) -> None:
        self._frame = frame_id

    def set_rate(self, rate: float) -> None:
        """0: stop, and clear the view."""
        rate = float(rate)
        if rate == self._rate:
            return
        if not rate:
            self._publish_clear()
        self._rate = rate
        self._wake.set()

    def clear(self) -> None:
        """Clear the view and forget the solutions offered (the home pose is next)."""
        self._latest = None
        self._publish_clear()

    def close(self) -> None:
        """End the thread and the renderer, destroy the publisher; idempotent."""
        if self._closed:
            return
        with self._lock:
            self._closed = True
            self._generation += 1
        self._wake.set()
        self._thread.join(JOIN_TIMEOUT)
        child = self._child
        if child is not None:
            if self._thread.is_alive():       # the renderer hangs: its pipe ends with it
                child.kill()
                self._thread.join(JOIN_TIMEOUT)
            for pipe in (child.stdin, child.stdout):
                try:
                    pipe.close()
                except OSError:
                    pass
            try:
                child.wait(JOIN_TIMEOUT)
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait()
        destroy = getattr(self._node, 'destroy_lifecycle_publisher', self._node.destroy_publisher)
        destroy(self._pub)

    def _publish_clear(self) -> None:
        with self._lock:
            self._generation += 1
            if not self._closed:
                self._pub.publish(clear_array(self._frame, *self._stamp))

    # -- the publisher's thread ----------------------------------------------------------
    def _run(self) -> None:
        """An array when one is due and an offer came, else half a period
        later (no setpoints: at the rate all the same).
        """
        rate = due = 0.0
        while not self._closed:
            if self._rate != rate:            # a new rate: its first array now
                rate, due = self._rate, time.monotonic()
                self._due = due if rate else math.inf
            if not rate:
                self._wake.wait()
                self._wake.clear()
                continue
            now = time.monotonic()
            late = due + 0.5 / rate
            if now < late and not (self._kicked and now >= due):
                self._wake.wait(late - now)
                self._wake.clear()
                continue
            due = max(due + 1.0 / rate, now)    # late: no catching up
            self._due, self._kicked = due, False
            try:
                if not self._tick():
                    return
            except Exception as exc:  # noqa: BLE001 - never into the node
                self._node.get_logger().error(f'markers not published: {type(exc).__name__}: '
                                              f'{exc}', throttle_duration_sec=LOG_THROTTLE)

    def _tick(self) -> bool:
        """One array, if anyone subscribes to them; False: the renderer is gone
        (logged).
        """
        if not getattr(self._pub, 'is_activated', True) or not self._pub.get_subscription_count():
            return True
        if self._child is None:
            with self._lock:
                if self._closed:
                    return False
                self._child = subprocess.Popen(
                    python_module(__name__), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                    env=node_env(), start_new_session=True)  # ends when our end of its pipe closes
        generation, latest, model = self._generation, self._latest, self._model
        if latest is None:
            header, snap = self._node.get_clock().now().seconds_nanoseconds(), None
        else:
            header, snap = latest[0], snapshot(self._machine, model, latest[1])
        # the model once per renderer, and again after a change
        sent = None if model is self._sent_model else model
        try:
            _write(self._child.stdin.fileno(), request(sent, self._frame, header, snap))
            reply = _read(self._child.stdout.fileno())
        except (OSError, ValueError):
            reply = None
        if reply is None:
            if not self._closed:
                self._node.get_logger().error(
                    f'markers stopped: their renderer ended (exit status {self._child.poll()})')
            return False
        self._sent_model = model
        if reply[:1] == b'E':
            self._node.get_logger().error('markers not drawn: ' + reply[1:].decode(),
                                          throttle_duration_sec=LOG_THROTTLE)
            return True
        with self._lock:
            if generation == self._generation and not self._closed:
                self._pub.publish(reply[1:])
                self._stamp = header
        return True


def request(model: Any, frame_id: str, header: tuple[int, int], snap: Snapshot | None) -> bytes:
    """A message to the renderer: the model (None: unchanged), the frame, the
    stamp and the snapshot to draw (None: home).
    """
    return pickle.dumps((model, frame_id, header, snap))


def render(message: bytes, builder: MarkerBuilder | None) -> tuple[bytes, MarkerBuilder | None]:
    """The renderer's answer to one message: ``M`` + the serialized array, or
    ``E`` + why not; and its builder (a new one for a new model).
    """
    try:
        model, frame_id, header, snap = pickle.loads(message)
        if model is not None:
            builder = None
            builder = MarkerBuilder(machine_of(model), model, frame_id)
        if builder is None:
            raise ValueError('no model to draw (building its drawing failed)')
        builder.frame_id = frame_id
        array = builder.update(builder.home if snap is None else snap, *header)
        return b'M' + serialize_message(array), builder
    except Exception as exc:  # noqa: BLE001 - told to the node, which logs it
        return b'E' + f'{type(exc).__name__}: {exc}'.encode(), builder


def idle_priority() -> None:
    """This process runs only on a core nothing else wants (Linux SCHED_IDLE,
    else the lowest nice): on a host of few cores, drawing never delays the
    node's or its planner's threads.
    """
    try:
        os.sched_setscheduler(0, os.SCHED_IDLE, os.sched_param(0))
    except (AttributeError, OSError):
        try:
            os.nice(19)
        except OSError:
            pass


def main() -> int:
    """The renderer: messages on stdin, answers on stdout, until stdin ends."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)    # the node ends it
    idle_priority()
    source, sink = sys.stdin.fileno(), sys.stdout.fileno()
    builder = None
    while (message := _read(source)) is not None:
        reply, builder = render(message, builder)
        _write(sink, reply)
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
