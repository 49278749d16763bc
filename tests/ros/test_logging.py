"""Agents' logs: do_log_msg, log_msg, start_log_subs/stop_log_subs and MCAP recording."""

from __future__ import annotations

import json
import math
import shutil
import threading
from pathlib import Path
from typing import Any

import pytest
from std_msgs.msg import String

from pyconnect.errors import PyconnectError
from pyconnect.record.bag_reader import open_bag

from .conftest import EVENT_TIMEOUT, repeat_until


def _json_values(directory: Path) -> list[Any]:
    return [json.loads(path.read_text()) for path in sorted(directory.glob("*.json"))]


def test_do_log_msg_writes_every_decoded_message(make_node: Any, tmp_path: Path) -> None:
    node = make_node("logger_node", log_dir=tmp_path)
    arrived = threading.Event()
    sub = node.add_agent(
        conn_name="chatter",
        conn_type="sub",
        data_interface=String,
        do_log_msg=True,
        response_func=lambda _value: arrived.set(),
    )
    pub = node.add_agent(
        conn_name="chatter", agent_name="out", conn_type="pub", data_interface=String
    )
    node.spin(run_thread=True)
    assert repeat_until(arrived, lambda: pub.send("logged"))
    assert sub.flush_log(EVENT_TIMEOUT)
    directory = sub.make_log_dirs()
    assert directory.parent.parent == tmp_path / "logger_node"
    assert directory.name == "chatter"
    assert set(_json_values(directory)) == {"logged"}


def test_log_msg_and_make_log_dirs(make_node: Any, tmp_path: Path) -> None:
    node = make_node("n", log_dir=tmp_path)
    node.add_agent(conn_name="a", conn_type="pub", data_interface=String)
    node.add_agent(conn_name="b", conn_type="pub", data_interface=String)
    directories = node.make_log_dirs()
    assert sorted(directories) == ["a", "b"]
    assert directories["a"].parent == directories["b"].parent
    agent = node.agents["a"]
    assert agent.log_msg({"cmd": "forward"}) is True
    assert agent.flush_log(EVENT_TIMEOUT)
    assert _json_values(directories["a"]) == [{"cmd": "forward"}]


def test_start_log_subs_logs_latest_values_and_records(make_node: Any, tmp_path: Path) -> None:
    node = make_node("periodic", log_dir=tmp_path / "logs")
    arrived = threading.Event()
    sub = node.add_agent(
        conn_name="status",
        conn_type="sub",
        data_interface=String,
        response_func=lambda _value: arrived.set(),
    )
    pub = node.add_agent(
        conn_name="status", agent_name="out", conn_type="pub", data_interface=String
    )
    bag = tmp_path / "subs.mcap"
    node.start_log_subs(fps=50, record=bag)
    assert node.is_logging_subs
    node.spin(run_thread=True)
    assert repeat_until(arrived, lambda: pub.send("fine"))
    logged = threading.Event()

    def check_logged() -> None:
        sub.flush_log(EVENT_TIMEOUT)
        if any(sub.make_log_dirs().glob("*.json")):
            logged.set()

    # The timer logs a value on its next tick after a new message.
    assert repeat_until(logged, check_logged)
    node.stop_log_subs()
    assert not node.is_logging_subs
    assert set(_json_values(sub.make_log_dirs())) == {"fine"}
    with open_bag(bag) as reader:
        recorded = [(topic, value) for topic, _stamp, value in reader]
    assert recorded
    assert set(recorded) == {("/status", "fine")}


def test_record_named_topics_until_stop(make_node: Any, tmp_path: Path) -> None:
    node = make_node("recorder")
    pub = node.add_agent(conn_name="events", conn_type="pub", data_interface=String)
    bag = tmp_path / "events.mcap"
    recording = node.record(bag, topics=["events"])
    assert recording.topics == ["/events"]
    node.spin(run_thread=True)
    written = threading.Event()

    def publish_and_check() -> None:
        pub.send("e")
        if recording.messages_written > 0:
            written.set()

    assert repeat_until(written, publish_and_check)
    recording.stop()
    recording.stop()
    with open_bag(bag) as reader:
        values = {value for _topic, _stamp, value in reader}
    assert values == {"e"}


def test_logged_rgb_images_keep_their_colours(make_node: Any, tmp_path: Path) -> None:
    import cv2
    import numpy as np
    from sensor_msgs.msg import Image

    from pyconnect.codecs.image import ImageCodec

    node = make_node("camera_logger", log_dir=tmp_path)
    arrived = threading.Event()
    sub = node.add_agent(
        conn_name="camera", conn_type="sub", data_interface=Image, do_log_msg=True,
        response_func=lambda _value: arrived.set(), qos="default",
    )  # fmt: skip
    pub = node.add_agent(
        conn_name="camera", agent_name="out", conn_type="pub", data_interface=Image, qos="default"
    )
    node.spin(run_thread=True)
    red = np.zeros((2, 3, 3), np.uint8)
    red[..., 0] = 255  # red in RGB order
    msg = ImageCodec(encoding="rgb8").encode(red)
    assert repeat_until(arrived, lambda: pub.send(msg))
    assert sub.flush_log(EVENT_TIMEOUT)
    written = cv2.imread(str(sorted(sub.make_log_dirs().glob("*.png"))[0]), cv2.IMREAD_UNCHANGED)
    # A PNG viewer must show red: OpenCV reads it back as BGR with the red in channel 2.
    assert written[..., 2].tolist() == [[255] * 3] * 2
    assert written[..., 0].tolist() == [[0] * 3] * 2


def test_agents_whose_names_clean_alike_log_into_their_own_folders(
    make_node: Any, tmp_path: Path
) -> None:
    node = make_node("folders", log_dir=tmp_path)
    relative = node.add_agent(conn_name="status", conn_type="pub", data_interface=String)
    absolute = node.add_agent(
        conn_name="/status", agent_name="/status", conn_type="pub", data_interface=String
    )
    assert relative.log_msg("relative") and absolute.log_msg("absolute")
    assert relative.flush_log(EVENT_TIMEOUT) and absolute.flush_log(EVENT_TIMEOUT)
    assert relative.make_log_dirs() != absolute.make_log_dirs()
    assert relative.make_log_dirs().parent == absolute.make_log_dirs().parent
    assert _json_values(relative.make_log_dirs()) == ["relative"]
    assert _json_values(absolute.make_log_dirs()) == ["absolute"]
    assert node.make_log_dirs() == {
        "status": relative.make_log_dirs(),
        "/status": absolute.make_log_dirs(),
    }


def test_do_log_msg_with_start_log_subs_writes_each_value_once(
    make_node: Any, tmp_path: Path
) -> None:
    node = make_node("once", log_dir=tmp_path)
    arrived = threading.Event()
    sub = node.add_agent(
        conn_name="chatter",
        conn_type="sub",
        data_interface=String,
        do_log_msg=True,
        response_func=lambda _value: arrived.set(),
    )
    pub = node.add_agent(
        conn_name="chatter", agent_name="out", conn_type="pub", data_interface=String
    )
    node.start_log_subs(fps=100)
    node.spin(run_thread=True)
    assert repeat_until(arrived, lambda: pub.send("only once") if not arrived.is_set() else None)
    # Let the start_log_subs timer tick a few times after the value arrived.
    ticked = threading.Event()
    ticks = node.add_agent(
        conn_name="ticks", conn_type="timer", time_period=0.01, response_func=lambda: None
    )
    assert repeat_until(ticked, lambda: ticked.set() if ticks.tick_count >= 20 else None)
    node.stop_log_subs()
    assert len(_json_values(sub.make_log_dirs())) == sub.message_count


def test_a_logged_image_is_the_one_received_not_what_response_func_drew_on_it(
    make_node: Any, tmp_path: Path
) -> None:
    import cv2
    import numpy as np
    from sensor_msgs.msg import Image

    node = make_node("drawing", log_dir=tmp_path)
    arrived = threading.Event()

    def draw(frame: Any) -> None:
        frame[...] = 255  # decoded images are writable: drawing on them is ordinary use
        arrived.set()

    sub = node.add_agent(
        conn_name="camera", conn_type="sub", data_interface=Image, do_log_msg=True,
        response_func=draw, qos="default",
    )  # fmt: skip
    pub = node.add_agent(
        conn_name="camera", agent_name="out", conn_type="pub", data_interface=Image, qos="default"
    )
    node.spin(run_thread=True)
    assert repeat_until(arrived, lambda: pub.send(np.zeros((2, 3), np.uint8)))
    assert sub.flush_log(EVENT_TIMEOUT)
    for path in sub.make_log_dirs().glob("*.png"):
        assert cv2.imread(str(path), cv2.IMREAD_UNCHANGED).max() == 0


def test_a_sent_value_is_logged_as_it_was_sent(make_node: Any, tmp_path: Path) -> None:
    node = make_node("sender", log_dir=tmp_path)
    pub = node.add_agent(conn_name="plan", conn_type="pub", data_interface=String)
    words = {"cmd": "forward"}
    assert pub.log_msg(words)
    words["cmd"] = "changed after logging"
    assert pub.flush_log(EVENT_TIMEOUT)
    assert _json_values(pub.make_log_dirs()) == [{"cmd": "forward"}]


def test_images_a_codec_converts_are_logged_in_their_decoded_channel_order(
    make_node: Any, tmp_path: Path
) -> None:
    import cv2
    import numpy as np
    from sensor_msgs.msg import Image

    from pyconnect.codecs.image import ImageCodec

    node = make_node("converting", log_dir=tmp_path)
    arrived = threading.Event()
    sub = node.add_agent(
        conn_name="camera", conn_type="sub", data_interface=Image, do_log_msg=True,
        codec=ImageCodec(encoding="bgr8"), response_func=lambda _value: arrived.set(),
        qos="default",
    )  # fmt: skip
    pub = node.add_agent(
        conn_name="camera", agent_name="out", conn_type="pub", data_interface=Image, qos="default"
    )
    node.spin(run_thread=True)
    red = np.zeros((2, 3, 3), np.uint8)
    red[..., 0] = 255  # red in RGB order, sent as rgb8; the codec hands on BGR pixels
    msg = ImageCodec(encoding="rgb8").encode(red)
    assert repeat_until(arrived, lambda: pub.send(msg))
    assert sub.flush_log(EVENT_TIMEOUT)
    written = cv2.imread(str(sorted(sub.make_log_dirs().glob("*.png"))[0]), cv2.IMREAD_UNCHANGED)
    assert written[..., 2].tolist() == [[255] * 3] * 2  # red, as OpenCV reads a PNG (BGR)
    assert written[..., 0].tolist() == [[0] * 3] * 2


def test_nodes_of_one_name_log_apart_across_namespaces_and_restarts(
    make_node: Any, tmp_path: Path
) -> None:
    first = make_node("driver", namespace="robot1", log_dir=tmp_path)
    second = make_node("driver", namespace="robot2", log_dir=tmp_path)
    plain = make_node("driver", log_dir=tmp_path)
    again = make_node("driver", log_dir=tmp_path)  # a respawn within the same second
    folders = []
    for node in (first, second, plain, again):
        agent = node.add_agent(conn_name="status", conn_type="pub", data_interface=String)
        assert agent.log_msg(node.get_namespace())
        assert agent.flush_log(EVENT_TIMEOUT)
        folders.append(agent.make_log_dirs())
    assert len(set(folders)) == 4
    assert [folder.parent.parent.name for folder in folders] == [
        "robot1__driver", "robot2__driver", "driver", "driver",
    ]  # fmt: skip
    assert [_json_values(folder) for folder in folders] == [["/robot1"], ["/robot2"], ["/"], ["/"]]


def test_a_log_folder_that_cannot_be_made_is_reported_and_send_still_works(
    make_node: Any, tmp_path: Path
) -> None:
    blocker = tmp_path / "not_a_folder"
    blocker.write_text("a file where the log root should be")
    node = make_node("unlogged", log_dir=blocker)
    pub = node.add_agent(
        conn_name="status", conn_type="pub", data_interface=String, do_log_msg=True
    )
    assert pub.send("published anyway") is True
    assert pub.send("again") is True
    assert pub.error_count == 1  # reported once, not per message
    assert "log_msg" in pub.last_error
    assert pub.log_msg("direct") is False


def test_logging_and_recording_after_shutdown_are_refused(make_node: Any, tmp_path: Path) -> None:
    node = make_node("closed_logger")
    node.add_agent(conn_name="chatter", conn_type="sub", data_interface=String)
    node.shutdown()
    with pytest.raises(PyconnectError) as logging_refused:
        node.start_log_subs(fps=10)
    assert str(logging_refused.value) == (
        "node '/closed_logger' is shut down; cannot start logging its subs"
    )
    target = tmp_path / "after_shutdown"
    with pytest.raises(PyconnectError) as record_refused:
        node.record(target)
    assert str(record_refused.value) == (
        f"node '/closed_logger' is shut down; cannot record to {str(target)!r}"
    )
    assert not target.exists()
    assert not (tmp_path / "after_shutdown.mcap").exists()


def test_the_default_log_dir_is_read_when_the_node_first_needs_it(
    make_node: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Set after pyconnect was imported, before the nodes exist (as a program's main() would).
    monkeypatch.setenv("PYCONNECT_LOG_DIR", str(tmp_path / "from_env"))
    by_env = make_node("env_logger", log_dir=None)
    assert by_env.log_dir == tmp_path / "from_env"
    monkeypatch.delenv("PYCONNECT_LOG_DIR")
    monkeypatch.chdir(tmp_path)
    by_cwd = make_node("cwd_logger", log_dir=None)
    assert by_cwd.log_dir == tmp_path / "pyconnect_logs"
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)  # once a node has its root it keeps it
    for node, root in ((by_env, tmp_path / "from_env"), (by_cwd, tmp_path / "pyconnect_logs")):
        agent = node.add_agent(conn_name="status", conn_type="pub", data_interface=String)
        assert agent.log_msg(node.get_name())
        assert agent.flush_log(EVENT_TIMEOUT)
        folder = agent.make_log_dirs()
        assert folder.parent.parent == root / node.get_name()
        assert _json_values(folder) == [node.get_name()]


def test_logging_subs_twice_names_the_node_as_remapped(make_node: Any) -> None:
    node = make_node("camera", namespace="robot1", cli_args=["--ros-args", "-r", "__node:=left"])
    node.start_log_subs(fps=10)
    with pytest.raises(PyconnectError) as caught:
        node.start_log_subs(fps=10)
    assert str(caught.value) == "node '/robot1/left' already logs its subs"


@pytest.mark.parametrize("fps", [0, -1, math.nan, math.inf, 1e-12, True, "10", None])
def test_start_log_subs_refuses_rates_no_timer_can_keep(make_node: Any, fps: object) -> None:
    # NaN passed ``fps <= 0``, inf made a 0 s timer that ran flat out, 1e-12 a period rclpy
    # refused with a bare TypeError.
    node = make_node("bad_fps")
    with pytest.raises(PyconnectError, match=r"^start_log_subs: fps must be a finite number > 0"):
        node.start_log_subs(fps=fps)  # type: ignore[arg-type]
    assert not node.is_logging_subs


def test_start_log_subs_logs_under_sim_time_without_a_clock(make_node: Any, tmp_path: Path) -> None:
    """The logging timer ran on the node's clock: with use_sim_time and no /clock it never
    fired, and nothing was logged."""
    node = make_node(
        "sim_logger", args=["--ros-args", "-p", "use_sim_time:=true"], log_dir=tmp_path / "logs"
    )
    sub = node.add_agent(conn_name="sim_log", conn_type="sub", data_interface=String)
    node.spin(run_thread=True)
    node.start_log_subs(fps=50)
    pub = make_node("sim_log_driver").create_publisher(String, "sim_log", 10)
    logged = threading.Event()

    def send() -> None:
        pub.publish(String(data="v"))
        if sub.message_count and any(p.is_file() for p in (tmp_path / "logs").rglob("*")):
            logged.set()

    assert repeat_until(logged, send)


def test_a_log_folder_removed_while_logging_is_made_again_or_reported_once(
    make_node: Any, tmp_path: Path
) -> None:
    # Removed under a do_log_msg agent, the folder gave an ERROR line per message, for ever,
    # and the agent's error said nothing.
    root = tmp_path / "logs"
    node = make_node("cleaned", log_dir=root)
    pub = node.add_agent(
        conn_name="status", conn_type="pub", data_interface=String, do_log_msg=True
    )
    assert pub.send("first") is True
    assert pub.flush_log(EVENT_TIMEOUT)
    folder = pub.make_log_dirs()
    shutil.rmtree(root)  # someone cleaning old logs: the folder is made again
    assert pub.send("second") is True
    assert pub.flush_log(EVENT_TIMEOUT)
    assert _json_values(folder) == ["second"]
    assert (pub.error_count, pub.last_error) == (0, None)
    shutil.rmtree(root)
    root.write_text("a file where the log root was")  # now it cannot be made again
    for i in range(5):
        assert pub.send(f"lost {i}") is True
    assert pub.flush_log(EVENT_TIMEOUT)
    assert pub.error_count == 1  # reported once, not per message
    assert pub.last_error.startswith(f"{pub.describe}: log_msg raised LogWriteError: {folder}: ")
    assert "the log folder was removed and cannot be made again" in pub.last_error
    assert pub._message_logger.failed == 5
