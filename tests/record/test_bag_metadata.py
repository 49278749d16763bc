"""metadata.yaml written with the items of its lists given as text: the text of the whole."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyconnect.record.bag_metadata import (
    BagMetadata,
    TopicMetadata,
    list_item_yaml,
    metadata_info,
    metadata_yaml,
    write_metadata,
)

_NAMES = ["run_0.mcap", "yes", "a b " * 25 + ".mcap", "x: #y", "é.mcap", "'q\"", "null"]


def _entry(k: int, name: str) -> dict[str, object]:
    return {
        "path": name,
        "starting_time": {"nanoseconds_since_epoch": 1_000 * k},
        "duration": {"nanoseconds": k},
        "message_count": k + 1,
    }


def _metadata(names: list[str], first: int) -> BagMetadata:
    """The bag of ``names``' files, from the ``first`` one on."""
    return BagMetadata(
        storage_identifier="mcap",
        relative_file_paths=tuple(names[first:]),
        topics=(TopicMetadata("/chatter", "std_msgs/msg/String", offered_qos_profiles="- a: 1\n"),),
        message_count=7,
        files=tuple(_entry(k, name) for k, name in enumerate(names) if k >= first),
    )


@pytest.mark.parametrize("given", range(len(_NAMES) + 1))
def test_items_given_as_text_make_the_text_of_the_whole(tmp_path: Path, given: int) -> None:
    """The first ``given`` files' items as text, the others in the metadata."""
    preceding = {
        "relative_file_paths": [list_item_yaml("relative_file_paths", n) for n in _NAMES[:given]],
        "files": [list_item_yaml("files", _entry(k, n)) for k, n in enumerate(_NAMES[:given])],
    }
    path = tmp_path / "metadata.yaml"
    write_metadata(path, _metadata(_NAMES, given), preceding=preceding)
    whole = metadata_yaml({"rosbag2_bagfile_information": metadata_info(_metadata(_NAMES, 0))})
    assert path.read_text(encoding="utf-8") == whole
