"""The node's setpoints and outputs on the wire: serialized (CDR) samples read
and written in place, with rclpy's own (de)serialisation as the fallback.

One entry point per message:

* :func:`read_pose`, :func:`read_twist`, :func:`read_accel` -- the stamp and
  the numbers of a serialized ``geometry_msgs/PoseStamped`` (7 doubles),
  ``TwistStamped`` or ``AccelStamped`` (6 doubles);
* :func:`read_trajectory` -- a serialized ``trajectory_msgs/JointTrajectory``
  (the ``platform_setpoint`` input) as a :class:`~.inputs.Trajectory`;
* :class:`JointStateOutput` -- a ``sensor_msgs/JointState`` output, kept
  serialized, whose stamp and values are overwritten every cycle.

Each reader returns ``(fields, fallback)``: ``fallback`` is True when the
sample was deserialized by rclpy (an encoding the CDR readers do not know, or
``fast=False``), so the node can count and log it. Why the hand-written path
exists at all: building the nested Python message of each sample costs more
than everything else the node does with it (docs/node.md, "What a cycle
costs", has the A/B figures of ``scripts/bench_callbacks.py``).
"""
from __future__ import annotations

import array
import struct
from typing import Any, Sequence

from geometry_msgs.msg import AccelStamped, PoseStamped, TwistStamped
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory

from .inputs import BAD_SETPOINT, SetpointError, Trajectory, TrajectoryPoint

#: (sec, nanosec, doubles) of a stamped message.
Stamped = tuple[int, int, tuple[float, ...]]

#: Encapsulation identifiers (first two bytes of a serialized DDS sample) of
#: plain XCDR1, which rmw_fastrtps and rmw_cyclonedds write for ROS messages.
CDR_BE, CDR_LE = b'\x00\x00', b'\x00\x01'


class StampedReader:
    """Read a serialized (CDR) ``geometry_msgs/*Stamped`` message without building
    the Python message: the header stamp and the ``count`` doubles that follow
    the header (PoseStamped: 7 = position x, y, z, orientation x, y, z, w;
    TwistStamped, AccelStamped: 6 = linear x, y, z, angular x, y, z).

    The node subscribes its setpoints serialized (``raw=True``): building the
    nested Python message of each sample costs more than the rest of its
    handling. Layout (XCDR1, plain CDR, either byte order): 4 bytes
    encapsulation, ``int32 sec``, ``uint32 nanosec``, ``uint32`` length of
    ``frame_id`` (its terminating NUL included) and its bytes, then the doubles,
    aligned to 8 bytes from the end of the encapsulation.

    Calling it returns ``(sec, nanosec, doubles)``, or None when the sample is
    in another encoding (the caller then deserializes it the usual way). A
    truncated sample raises ``struct.error``.
    """

    __slots__ = ('count', '_le', '_be')

    def __init__(self, count: int) -> None:
        self.count = count
        self._le = (struct.Struct('<iII'), struct.Struct(f'<{count}d'))
        self._be = (struct.Struct('>iII'), struct.Struct(f'>{count}d'))

    def __call__(self, data: bytes) -> tuple[int, int, tuple[float, ...]] | None:
        if data[0] != 0:
            return None
        encoding = data[1]
        if encoding == 1:
            head, body = self._le
        elif encoding == 0:
            head, body = self._be
        else:
            return None
        sec, nanosec, length = head.unpack_from(data, 4)
        offset = 16 + length               # 4 encapsulation + 12 header bytes + frame_id
        offset += (4 - offset) % 8         # align the doubles (relative to byte 4)
        return sec, nanosec, body.unpack_from(data, offset)


read_pose_stamped = StampedReader(7)
read_twist_stamped = StampedReader(6)        # and AccelStamped: the same layout

#: Fewest bytes of a serialized JointTrajectoryPoint: four sequence counts
#: (empty sequences) and a Duration.
_MIN_POINT_BYTES = 24
_MAX_CACHED_DOUBLES = 8


class _CdrFormats:
    """The struct formats of one byte order (``order``: '<' or '>')."""

    __slots__ = ('order', 'head', 'u32', 'duration', 'doubles')

    def __init__(self, order: str) -> None:
        self.order = order
        self.head = struct.Struct(order + 'iII')           # stamp sec, nanosec, len(frame_id)
        self.u32 = struct.Struct(order + 'I')
        self.duration = struct.Struct(order + 'iI')
        self.doubles = tuple(struct.Struct(f'{order}{n}d')
                             for n in range(_MAX_CACHED_DOUBLES + 1))

    def double_struct(self, n: int) -> struct.Struct:
        return self.doubles[n] if n <= _MAX_CACHED_DOUBLES else struct.Struct(f'{self.order}{n}d')


def _read_doubles(data: bytes, at: int, fmt: _CdrFormats) -> tuple[tuple[float, ...], int]:
    """A ``float64[]`` of a serialized sample at byte ``at``: (values, end)."""
    at += -at & 3
    (n,) = fmt.u32.unpack_from(data, at)
    at += 4
    if not n:
        return (), at                      # no alignment without elements
    at += (4 - at) & 7                     # doubles: 8-aligned relative to byte 4
    end = at + 8 * n
    if end > len(data):
        raise struct.error(f'a sequence of {n} doubles at byte {at} runs past the end '
                           f'({len(data)} bytes)')
    return fmt.double_struct(n).unpack_from(data, at), end


class TrajectoryReader:
    """Read a serialized (CDR) ``trajectory_msgs/JointTrajectory`` without
    building the Python message (the ``platform_setpoint`` input; the same
    reasons as :class:`StampedReader`).

    Layout (XCDR1, plain CDR, either byte order; alignment of every field to
    its size counted from the end of the 4-byte encapsulation):

    * ``std_msgs/Header``: ``int32 sec``, ``uint32 nanosec``, ``frame_id``
      (``uint32`` length including the terminating NUL, then the bytes);
    * ``string[] joint_names``: ``uint32`` count, then each string as above
      (each length aligned to 4);
    * ``JointTrajectoryPoint[] points``: ``uint32`` count, then per point the
      sequences ``positions``, ``velocities``, ``accelerations``, ``effort``
      (``uint32`` count, then the doubles aligned to 8 when there are any)
      and ``time_from_start`` (``int32 sec``, ``uint32 nanosec``).

    Calling it returns a :class:`Trajectory`, or None when the sample is in
    another encoding (the caller then deserializes it the usual way). A
    truncated or inconsistent sample raises ``struct.error`` (never reads
    past the end of ``data``, never loops longer than ``data`` is long).
    Names are decoded as UTF-8 (undecodable bytes replaced: such a name is
    wrong anyway and the rejection shows it). Bytes after the message are
    ignored.

    Cheap in the usual case (one point, the same three names in every
    message): the parsed names are kept with the bytes they came from (count,
    lengths and characters; not the padding, whose bytes are arbitrary), and a
    message whose name bytes match gets the same tuple without parsing.
    """

    __slots__ = ('_le', '_be', '_names', '_names_encoding', '_names_parts', '_names_size')

    def __init__(self) -> None:
        self._le = _CdrFormats('<')
        self._be = _CdrFormats('>')
        self._names: tuple[str, ...] = ()
        self._names_encoding = -1
        self._names_parts: tuple[tuple[int, bytes], ...] = ()
        self._names_size = 0

    def __call__(self, data: bytes, max_points: int | None = None) -> Trajectory | None:
        if len(data) < 4:
            raise struct.error(f'{len(data)} bytes: not even an encapsulation header')
        if data[0] != 0:
            return None
        encoding = data[1]
        if encoding == 1:
            fmt = self._le
        elif encoding == 0:
            fmt = self._be
        else:
            return None
        size = len(data)
        sec, nanosec, length = fmt.head.unpack_from(data, 4)
        at = 16 + length                   # 4 encapsulation + 12 header bytes + frame_id
        at += -at & 3                      # 4-aligned (relative to byte 4 = absolute)
        names, at = self._joint_names(data, at, encoding, fmt)
        at += -at & 3
        u32 = fmt.u32.unpack_from
        (count,) = u32(data, at)
        at += 4
        if max_points is not None and count > max_points:
            raise too_many_points(count, max_points)
        if count > (size - at) // _MIN_POINT_BYTES:
            raise struct.error(f'{count} points cannot fit in the {size - at} bytes left')
        duration = fmt.duration.unpack_from
        make_point = TrajectoryPoint._make       # cheaper than the keyword-capable __new__
        points = []
        for _ in range(count):
            positions, at = _read_doubles(data, at, fmt)
            velocities, at = _read_doubles(data, at, fmt)
            accelerations, at = _read_doubles(data, at, fmt)
            effort, at = _read_doubles(data, at, fmt)
            at += -at & 3
            t_sec, t_nanosec = duration(data, at)
            at += 8
            points.append(make_point((positions, velocities, accelerations, effort,
                                      t_sec, t_nanosec)))
        return Trajectory._make((sec, nanosec, names, tuple(points)))

    def _joint_names(self, data: bytes, at: int, encoding: int, fmt: _CdrFormats
                     ) -> tuple[tuple[str, ...], int]:
        """``joint_names`` starting at byte ``at`` (4-aligned): (names, end)."""
        if encoding == self._names_encoding:
            for offset, chunk in self._names_parts:
                if not data.startswith(chunk, at + offset):
                    break
            else:
                return self._names, at + self._names_size
        size = len(data)
        u32 = fmt.u32.unpack_from
        start = at
        (count,) = u32(data, at)
        at += 4
        if count > (size - at) // 4:
            raise struct.error(f'{count} joint names cannot fit in the {size - at} bytes left')
        names = []
        parts = []
        chunk_at = start                   # the current run of bytes without padding
        for _ in range(count):
            aligned = at + (-at & 3)
            if aligned != at:
                parts.append((chunk_at - start, data[chunk_at:at]))
                chunk_at = aligned
            (n,) = u32(data, aligned)
            at = aligned + 4 + n
            if at > size:
                raise struct.error(f'a string of {n} bytes at byte {aligned + 4} runs past '
                                   f'the end ({size} bytes)')
            raw = data[aligned + 4:at]
            if raw and raw[-1] == 0:
                raw = raw[:-1]
            names.append(raw.decode('utf-8', 'replace'))
        parts.append((chunk_at - start, data[chunk_at:at]))
        result = tuple(names)
        self._names, self._names_encoding = result, encoding
        self._names_parts, self._names_size = tuple(parts), at - start
        return result, at


read_joint_trajectory = TrajectoryReader()



# ----------------------------------------------------------------------------
# rclpy's deserialisation: the fallback (and the reference the readers are
# tested against)
# ----------------------------------------------------------------------------
def _pose_fields(msg: PoseStamped) -> tuple[int, int, tuple[float, ...]]:
    """What :data:`read_pose_stamped` reads, from a PoseStamped."""
    p, o = msg.pose.position, msg.pose.orientation
    return (msg.header.stamp.sec, msg.header.stamp.nanosec,
            (p.x, p.y, p.z, o.x, o.y, o.z, o.w))


def _rate_fields(msg: Any) -> tuple[int, int, tuple[float, ...]]:
    """What :data:`read_twist_stamped` reads, from a TwistStamped or
    AccelStamped.
    """
    body = msg.twist if isinstance(msg, TwistStamped) else msg.accel
    lin, ang = body.linear, body.angular
    return (msg.header.stamp.sec, msg.header.stamp.nanosec,
            (lin.x, lin.y, lin.z, ang.x, ang.y, ang.z))


def _trajectory_fields(msg: JointTrajectory) -> Trajectory:
    """What :data:`read_joint_trajectory` reads, from a JointTrajectory."""
    stamp = msg.header.stamp
    return Trajectory(stamp.sec, stamp.nanosec, tuple(msg.joint_names), tuple(
        TrajectoryPoint(tuple(p.positions), tuple(p.velocities), tuple(p.accelerations),
                        tuple(p.effort), p.time_from_start.sec, p.time_from_start.nanosec)
        for p in msg.points))


# ----------------------------------------------------------------------------
# The entry points: the CDR reader, else rclpy
# ----------------------------------------------------------------------------
def read_pose(data: bytes, fast: bool = True) -> tuple[Stamped, bool]:
    """(sec, nanosec, position x, y, z and orientation x, y, z, w) of a
    serialized PoseStamped, and whether rclpy deserialized it. Raises
    (``struct.error`` or rclpy's error) on a malformed sample.
    """
    if fast:
        fields = read_pose_stamped(data)
        if fields is not None:
            return fields, False
    return _pose_fields(deserialize_message(data, PoseStamped)), True


def read_twist(data: bytes, fast: bool = True) -> tuple[Stamped, bool]:
    """(sec, nanosec, linear x, y, z and angular x, y, z) of a serialized
    TwistStamped, and whether rclpy deserialized it (as :func:`read_pose`).
    """
    if fast:
        fields = read_twist_stamped(data)
        if fields is not None:
            return fields, False
    return _rate_fields(deserialize_message(data, TwistStamped)), True


def read_accel(data: bytes, fast: bool = True) -> tuple[Stamped, bool]:
    """(sec, nanosec, linear x, y, z and angular x, y, z) of a serialized
    AccelStamped, and whether rclpy deserialized it (as :func:`read_pose`).
    """
    if fast:
        fields = read_twist_stamped(data)         # the same layout as TwistStamped
        if fields is not None:
            return fields, False
    return _rate_fields(deserialize_message(data, AccelStamped)), True


#: Bytes one valid point takes at most (3 positions, velocities and
#: accelerations, no effort, time_from_start, padding), and a message's bytes
#: besides its points (header, frame_id, joint_names): bounds the size of a
#: message of ``max_points`` points.
MAX_POINT_BYTES = 128
MAX_MESSAGE_OVERHEAD = 65536


def too_many_points(count: int, max_points: int) -> SetpointError:
    """The rejection of a platform_setpoint of ``count`` > ``max_points`` points."""
    return SetpointError(BAD_SETPOINT, f'{count} points, more than input.max_points = '
                                       f'{max_points} (not decoded)')


def read_trajectory(data: bytes, fast: bool = True, max_points: int | None = None
                    ) -> tuple[Trajectory, bool]:
    """The fields of a serialized JointTrajectory, and whether rclpy
    deserialized it (as :func:`read_pose`). With ``max_points``, a message of
    more points raises :class:`SetpointError` (``bad_setpoint``) before its
    points are decoded: at once when its size alone shows it, else once the
    count is read.
    """
    if max_points is not None and len(data) > MAX_MESSAGE_OVERHEAD + max_points * MAX_POINT_BYTES:
        raise SetpointError(BAD_SETPOINT, f'{len(data)} bytes: more than a message of '
                                          f'input.max_points = {max_points} points can take '
                                          '(not decoded)')
    if fast:
        fields = read_joint_trajectory(data, max_points)
        if fields is not None:
            return fields, False
    fields = _trajectory_fields(deserialize_message(data, JointTrajectory))
    if max_points is not None and len(fields.points) > max_points:
        raise too_many_points(len(fields.points), max_points)
    return fields, True


# ----------------------------------------------------------------------------
# Outputs
# ----------------------------------------------------------------------------
class JointStateOutput:
    """One output topic's ``sensor_msgs/JointState``, reused every cycle.

    Names and ``header.frame_id`` are fixed; per cycle only the stamp and the
    value arrays change (their lengths never do). So the message is kept
    *serialized*: a template built once by the middleware's own serializer,
    in which :meth:`fill` overwrites the stamp and the doubles in place, and
    which is published as bytes (``Publisher.publish`` takes a serialized
    message). That skips converting the Python message to C and serializing
    it again every cycle: the wire bytes are the same.

    The template is checked once, by deserializing a filled copy; if the
    middleware's encoding is not one this class understands, ``raw`` is
    False and :meth:`fill` returns the message object with its arrays
    replaced instead (the old way: correct, slower).

    ``names``: joint names; ``frame_id``; ``arrays``: how many value arrays
    are filled (3: position, velocity, effort; 2: position, velocity, effort
    left empty); ``fast`` False: no template, the message object always (the
    A/B benchmark's rclpy path).
    """

    FIELDS = ('position', 'velocity', 'effort')

    def __init__(self, names: Sequence[str], frame_id: str, arrays: int = 3,
                 fast: bool = True) -> None:
        self.msg = JointState()
        self.msg.name = list(names)
        self.msg.header.frame_id = frame_id
        self.size = len(names)
        self.arrays = arrays
        self._fields = self.FIELDS[:arrays]
        self.raw = False
        self._buf = bytearray()
        self._stamp_at = 0
        self._value_at: tuple[int, ...] = ()
        self._stamp_struct = struct.Struct('<iI')
        self._values_struct = struct.Struct(f'<{self.size}d')
        if fast:
            try:
                self.raw = self._build_template()
            except Exception:  # noqa: BLE001 - any surprise: publish the message object
                self.raw = False

    def _build_template(self) -> bool:
        """Serialize the message with recognisable values and find where the
        stamp and each array went; True when a filled copy deserializes back
        exactly.
        """
        n = self.size
        msg = self.msg
        # distinct, finite, unlikely 8-byte patterns
        marks = [[(1.0 + (i * n + k + 1) * 2.0 ** -30) * 2.0 ** 999 for k in range(n)]
                 for i in range(self.arrays)]
        for name, values in zip(self._fields, marks):
            setattr(msg, name, array.array('d', values))
        msg.header.stamp.sec, msg.header.stamp.nanosec = 0x1A2B3C4D, 0x2B3C4D5E
        data = serialize_message(msg)
        order = {CDR_LE: '<', CDR_BE: '>'}.get(bytes(data[:2]))
        if order is None:
            return False
        stamp_struct = struct.Struct(order + 'iI')
        values_struct = struct.Struct(f'{order}{n}d')

        def only(pattern: bytes) -> int:
            at = data.find(pattern)
            if at < 0 or data.find(pattern, at + 1) >= 0:
                raise ValueError('pattern not found exactly once')
            return at

        self._stamp_at = only(stamp_struct.pack(0x1A2B3C4D, 0x2B3C4D5E))
        self._value_at = tuple(only(values_struct.pack(*values)) for values in marks)
        self._stamp_struct, self._values_struct = stamp_struct, values_struct
        self._buf = bytearray(data)
        # check: a filled copy must read back as the message it stands for
        check = [[(i + 1) * 10.0 + k * 0.5 for k in range(n)] for i in range(self.arrays)]
        back = deserialize_message(self._fill_raw(-7, 999_999_999, check), JointState)
        ok = (list(back.name) == list(msg.name) and back.header.frame_id == msg.header.frame_id
              and (back.header.stamp.sec, back.header.stamp.nanosec) == (-7, 999_999_999)
              and all(list(getattr(back, name)) == values
                      for name, values in zip(self._fields, check))
              and all(len(getattr(back, name)) == 0 for name in self.FIELDS[self.arrays:]))
        for name in self._fields:
            setattr(msg, name, array.array('d', [0.0] * n))
        msg.header.stamp.sec = msg.header.stamp.nanosec = 0
        return ok

    def _fill_raw(self, sec: int, nanosec: int, values: Sequence[Sequence[float]]) -> bytes:
        buf = self._buf
        self._stamp_struct.pack_into(buf, self._stamp_at, sec, nanosec)
        pack = self._values_struct.pack_into
        for at, vals in zip(self._value_at, values):
            pack(buf, at, *vals)
        return bytes(buf)

    def fill(self, sec: int, nanosec: int, *values: Sequence[float]) -> Any:
        """The message for this cycle: stamp ``sec``/``nanosec``, then one
        sequence of ``len(names)`` floats per array. Serialized bytes when
        ``raw``, else the (reused) JointState.
        """
        if self.raw:
            return self._fill_raw(sec, nanosec, values)
        msg = self.msg
        stamp = msg.header.stamp
        stamp.sec, stamp.nanosec = sec, nanosec
        for name, vals in zip(self._fields, values):
            # array('d') is taken as is by the message setters (no per-element checks)
            setattr(msg, name, array.array('d', vals))
        return msg


