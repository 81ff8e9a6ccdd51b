"""quadcos's own TensorBoard event files, read back with tensorboardX's independent checksum
and protocol buffers (tensorboardX comes with brax)."""

import struct

from tensorboardX.proto import event_pb2
from tensorboardX.record_writer import masked_crc32c

from quadcos._util import tensorboard


def _records(path):
    data = path.read_bytes()
    offset = 0
    while offset < len(data):
        header = data[offset : offset + 8]
        (length,) = struct.unpack("<Q", header)
        (header_crc,) = struct.unpack("<I", data[offset + 8 : offset + 12])
        record = data[offset + 12 : offset + 12 + length]
        (record_crc,) = struct.unpack("<I", data[offset + 12 + length : offset + 16 + length])
        assert header_crc == masked_crc32c(header)
        assert record_crc == masked_crc32c(record)
        yield event_pb2.Event.FromString(record)
        offset += 16 + length


def test_scalars_read_back_as_tensorboard_events(tmp_path):
    writer = tensorboard.ScalarWriter(tmp_path / "tb")
    writer.add_scalar("eval/forward_speed", 0.875, 1024)
    writer.add_scalar("train/alpha_loss", -3.5e-4, 2**40)
    writer.close()
    (path,) = (tmp_path / "tb").iterdir()
    assert "tfevents" in path.name
    version, speed, loss = _records(path)
    assert version.file_version == "brain.Event:2" and version.wall_time > 0
    assert speed.step == 1024 and speed.summary.value[0].tag == "eval/forward_speed"
    assert speed.summary.value[0].simple_value == 0.875
    assert loss.step == 2**40 and loss.summary.value[0].simple_value == struct.unpack(
        "<f", struct.pack("<f", -3.5e-4)
    )[0]


def test_a_resumed_log_purges_from_its_step(tmp_path):
    writer = tensorboard.ScalarWriter(tmp_path, purge_step=5121)
    writer.close()
    _, purge = _records(writer.path)
    assert purge.step == 5121 and purge.session_log.status == event_pb2.SessionLog.START
