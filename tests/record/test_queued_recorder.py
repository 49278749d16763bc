"""QueuedRecorder: writes never wait for a split, nothing queued is lost, failures are raised."""

from __future__ import annotations

import contextlib
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from rclpy.serialization import serialize_message
from std_msgs.msg import String

from pyconnect.record import open_bag
from pyconnect.record.bag_errors import BagError
from pyconnect.record.queued_recorder import QueuedRecorder
from pyconnect.record.split_recorder import SplitRecorder
from tests.record.test_split_recorder import _metadata, _noise, fill_disk

WAIT = 60.0


def _hello(i: int) -> bytes:
    return bytes(serialize_message(String(data=f"hello {i}")))


def test_writes_return_while_a_split_is_stuck_and_all_land_in_order(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    bag = tmp_path / "run"
    split = SplitRecorder(bag, max_bytes=1)  # a new file after every message
    split.add_topic("/chatter", "std_msgs/msg/String")
    in_split = threading.Event()
    release = threading.Event()
    open_next = SplitRecorder._open_next

    def slow_open_next(self: SplitRecorder) -> Any:
        in_split.set()
        assert release.wait(WAIT)  # a slow disk: the split takes as long as the test wants
        return open_next(self)

    monkeypatch.setattr(SplitRecorder, "_open_next", slow_open_next)
    recorder = QueuedRecorder(split)
    written = threading.Event()

    def subscription_callbacks() -> None:
        for i in range(200):
            recorder.write("/chatter", _hello(i), log_time_ns=i)
        written.set()

    try:
        threading.Thread(target=subscription_callbacks, daemon=True).start()
        assert in_split.wait(WAIT)
        # Every write returned while the writer thread is still inside the first split.
        assert written.wait(WAIT)
        assert not release.is_set() and recorder.pending >= 198
    finally:
        release.set()
        recorder.close()
    assert split.counts == {"/chatter": 200}
    assert len(split.files) == 200
    with open_bag(bag) as reader:
        assert [m.value for m in reader] == [f"hello {i}" for i in range(200)]
        assert (reader.errors, reader.damage) == ([], [])


def test_a_failed_writer_is_reported_with_what_it_did_not_write(tmp_path: Path) -> None:
    bag = tmp_path / "run"
    split = SplitRecorder(bag)
    split.add_topic("/chatter", "std_msgs/msg/String")
    recorder = QueuedRecorder(split)
    recorder.write("/chatter", _hello(0), log_time_ns=0)
    recorder.write("/unknown", _hello(1), log_time_ns=1)  # the writer fails on this one
    with pytest.raises(BagError) as failed:
        recorder.close()
    assert str(failed.value) == (  # received and not written: the one that failed
        f"{bag}: writing the bag failed (/unknown: not added to this recording; call add_topic "
        "first); 1 received message(s) not written"
    )
    recorder.close()  # reported once; the bag is finished with what was written
    with open_bag(bag) as reader:
        assert [m.value for m in reader] == ["hello 0"]
    with pytest.raises(BagError, match="recording is closed"):
        recorder.write("/chatter", _hello(2), log_time_ns=2)


def test_a_bag_the_full_disk_cut_short_is_a_bag_error_with_what_it_lost(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Every write fits in the chunk in memory; finishing the file meets the full disk.
    bag = tmp_path / "run"
    split = SplitRecorder(bag, compression="none")
    split.add_topic("/noise", "std_msgs/msg/String")
    fill_disk(monkeypatch, 10_000)
    recorder = QueuedRecorder(split)
    for i in range(40):
        recorder.write("/noise", _noise(i), log_time_ns=1_000 + i)
    with pytest.raises(BagError) as failed:
        recorder.close()
    recorder.close()  # reported once
    with open_bag(bag) as reader:
        held = sum(1 for _ in reader)
    assert 0 < held < 40
    assert str(failed.value) == (
        f"{bag}: writing the bag failed ([Errno 28] No space left on device); "
        f"{40 - held} received message(s) not written"
    )
    assert isinstance(failed.value.__cause__, OSError)
    assert (split.counts, _metadata(bag)["message_count"]) == ({"/noise": held}, held)


def test_a_failed_writer_then_a_failed_finish_are_one_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    bag = tmp_path / "run"
    split = SplitRecorder(bag, max_bytes=3_000, compression="none")  # chunks of 3 messages
    split.add_topic("/noise", "std_msgs/msg/String")
    fill_disk(monkeypatch, 7_000)  # full in the second file's first chunk, not at a split
    recorder = QueuedRecorder(split)
    for i in range(40):  # a chunk meets the full disk on the writer thread; the rest wait
        recorder.write("/noise", _noise(i), log_time_ns=1_000 + i)
    with pytest.raises(BagError) as failed:
        recorder.close()  # finishing the file meets it again: told, not in the first's place
    with open_bag(bag) as reader:
        held = sum(1 for _ in reader)
    assert 0 < held < 40
    assert str(failed.value) == (
        f"{bag}: writing the bag failed ([Errno 28] No space left on device); "
        f"{40 - held} received message(s) not written; finishing it failed too ([Errno 28] No "
        "space left on device)"
    )
    written, finishing = failed.value.__cause__, failed.value.__context__
    assert isinstance(written, OSError) and isinstance(finishing, OSError)
    assert written is not finishing
    assert (split.counts, _metadata(bag)["message_count"]) == ({"/noise": held}, held)


def test_a_bag_directory_removed_while_recorded_is_a_bag_error_that_counts_all_lost(
    tmp_path: Path,
) -> None:
    bag = tmp_path / "run"
    split = SplitRecorder(bag, max_bytes=1)  # a new file after every message
    split.add_topic("/chatter", "std_msgs/msg/String")
    recorder = QueuedRecorder(split)
    for i in range(3):
        recorder.write("/chatter", _hello(i), log_time_ns=1_000 + i)
    _wait_until(lambda: recorder.pending == 0 and len(split.files) >= 3)
    for path in bag.iterdir():
        path.unlink()
    bag.rmdir()
    for i in range(3, 6):  # the first of them needs the next file: the writer fails there
        with contextlib.suppress(BagError):
            recorder.write("/chatter", _hello(i), log_time_ns=1_000 + i)
    with pytest.raises(BagError) as failed:
        recorder.close()
    assert str(failed.value) == (
        f"{bag}: writing the bag failed ({bag}: the directory was removed while it was "
        "recorded, its files with it); 6 received message(s) not written"
    )
    assert not bag.exists()  # not made again for the rest of the recording
    assert split.counts == {"/chatter": 0}


def _wait_until(done: Any) -> None:
    for _ in range(int(WAIT / 0.01)):
        if done():
            return
        time.sleep(0.01)
    pytest.fail("timed out")
