"""TensorBoard scalars without TensorBoard: an event file (TFRecord framing of `Event` protocol
buffers, encoded here) that TensorBoard reads as tensorboardX's or TensorFlow's writers' files.

Written by hand because tensorboardX imports PyTorch when it is installed (seconds at every run's
start) and scalars need only a few protobuf fields: `Event` {1 wall_time: double, 2 step: int64,
3 file_version: string, 5 summary: Summary, 7 session_log: SessionLog}, `Summary` {1 value:
repeated Value}, `Value` {1 tag: string, 2 simple_value: float}, `SessionLog` {1 status: enum}.
"""

import os
import pathlib
import socket
import struct
import time

_SESSION_START = 1  # SessionLog.START: TensorBoard drops the events at and after its step


def _crc32c_table() -> list[int]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc >> 1) ^ (0x82F63B78 if crc & 1 else 0)
        table.append(crc)
    return table


_CRC32C = _crc32c_table()


def _masked_crc32c(data: bytes) -> int:
    """TFRecord's checksum: CRC-32C (Castagnoli), rotated and offset."""
    crc = 0xFFFFFFFF
    for byte in data:
        crc = _CRC32C[(crc ^ byte) & 0xFF] ^ (crc >> 8)
    crc ^= 0xFFFFFFFF
    return (((crc >> 15) | (crc << 17)) + 0xA282EAD8) & 0xFFFFFFFF


def _varint(value: int) -> bytes:
    value &= (1 << 64) - 1  # int64 as protobuf encodes it
    out = bytearray()
    while value > 0x7F:
        out.append((value & 0x7F) | 0x80)
        value >>= 7
    out.append(value)
    return bytes(out)


def _field(number: int, payload: bytes) -> bytes:
    """A length-delimited field (wire type 2)."""
    return _varint(number << 3 | 2) + _varint(len(payload)) + payload


def _event(step: int | None, **fields: bytes) -> bytes:
    wall_time = struct.pack("<d", time.time())
    event = _varint(1 << 3 | 1) + wall_time
    if step is not None:
        event += _varint(2 << 3) + _varint(step)
    numbers = {"file_version": 3, "summary": 5, "session_log": 7}
    for name, payload in fields.items():
        event += _field(numbers[name], payload)
    return event


class ScalarWriter:
    """Appends scalars to a new event file in `directory`; `purge_step` (resuming): TensorBoard
    drops what earlier files of the directory logged at and after that step."""

    def __init__(self, directory: str | os.PathLike[str], purge_step: int | None = None):
        directory = pathlib.Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        name = f"events.out.tfevents.{time.time():.6f}.{socket.gethostname()}.{os.getpid()}"
        self.path = directory / name
        self._file = open(self.path, "ab")  # noqa: SIM115 (closed by close())
        self._write(_event(None, file_version=b"brain.Event:2"))
        if purge_step is not None:
            status = _varint(1 << 3) + _varint(_SESSION_START)
            self._write(_event(purge_step, session_log=status))

    def add_scalar(self, tag: str, value: float, step: int) -> None:
        value_proto = _field(1, tag.encode()) + _varint(2 << 3 | 5) + struct.pack("<f", value)
        self._write(_event(step, summary=_field(1, value_proto)))

    def flush(self) -> None:
        self._file.flush()

    def close(self) -> None:
        self._file.close()

    def _write(self, record: bytes) -> None:
        length = struct.pack("<Q", len(record))
        self._file.write(
            length
            + struct.pack("<I", _masked_crc32c(length))
            + record
            + struct.pack("<I", _masked_crc32c(record))
        )
