"""Every way a program ends is clean: stop_func once, threads joined, exit code 0 (subprocesses)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from .conftest import EVENT_TIMEOUT

PRELUDE = """
import sys, threading, time
from std_msgs.msg import String
from pyconnect.ros.custom_node import CustomNode

def say(word):
    # One write per line: two nodes stop on two threads at once.
    sys.stdout.write(word + "\\n")
    sys.stdout.flush()

def make():
    node = CustomNode("shutdown_child", stop_func=lambda: say("STOP"))
    heard = threading.Event()
    node.add_agent(conn_name="beat", conn_type="sub", data_interface=String,
                   response_func=lambda _v: heard.set())
    node.add_agent(conn_name="beat", agent_name="beat_out", conn_type="pub",
                   data_interface=String, time_period=0.01, response_func=lambda: "tick")
    return node, heard

def ready(heard):
    if not heard.wait(60):
        print("NO TRAFFIC", flush=True)
    print("READY", flush=True)

def ready_when_main_waits(node, heard):
    # Signals sent before the main thread waits in spin()/wait_for_shutdown() end the program
    # with SystemExit(0) instead of a normal return; these endings test the return.
    while not node._main_waiting:
        heard.wait(0.01)
    ready(heard)
"""

ENDINGS = {
    "sigint_blocking_spin": """
node, heard = make()
threading.Thread(target=ready_when_main_waits, args=(node, heard), daemon=True).start()
node.spin()
print("AFTER SPIN", flush=True)
""",
    "sigint_thread_wait_for_shutdown": """
node, heard = make()
node.spin(run_thread=True)
threading.Thread(target=ready_when_main_waits, args=(node, heard), daemon=True).start()
node.wait_for_shutdown()
print("AFTER WAIT", flush=True)
""",
    "sigint_thread_user_loop": """
node, heard = make()
node.spin(run_thread=True)
ready(heard)
while True:
    time.sleep(0.05)
""",
    "sigterm_thread_user_loop": """
node, heard = make()
node.spin(run_thread=True)
ready(heard)
while True:
    time.sleep(0.05)
""",
    "shutdown_call": """
node, heard = make()
node.spin(run_thread=True)
ready(heard)
node.shutdown()
node.shutdown()
print("AFTER SHUTDOWN", flush=True)
""",
    "with_block": """
with make()[0] as node:
    node.spin(run_thread=True)
    heard = threading.Event()
    node.add_agent(conn_name="beat", agent_name="probe", conn_type="sub", data_interface=String,
                   response_func=lambda _v: heard.set())
    ready(heard)
print("AFTER WITH", flush=True)
""",
    "sigint_two_nodes": """
node, heard = make()
other = CustomNode("second_child", stop_func=lambda: say("STOP2"))
node.spin(run_thread=True)
other.spin(run_thread=True)
threading.Thread(target=ready_when_main_waits, args=(node, heard), daemon=True).start()
node.wait_for_shutdown()
other.wait_for_shutdown()
print("AFTER TWO", flush=True)
""",
    "sigint_async_handlers_busy": """
import asyncio
from std_srvs.srv import Trigger

node, heard = make()
started = threading.Event()

async def slow_sub(_value):
    started.set()
    await asyncio.sleep(600)

async def slow_service(_request):
    await asyncio.sleep(600)

node.add_agent(conn_name="beat", agent_name="slow", conn_type="sub", data_interface=String,
               response_func=slow_sub)
node.add_agent(conn_name="hang", conn_type="service_server", data_interface=Trigger,
               response_func=slow_service)
client = node.add_agent(conn_name="hang", agent_name="hang_client",
                        conn_type="service_client", data_interface=Trigger)
node.spin(run_thread=True)
pending = client.send(block=False)
started.wait(60)
threading.Thread(target=ready_when_main_waits, args=(node, heard), daemon=True).start()
node.wait_for_shutdown()
print("AFTER BUSY", flush=True)
""",
    "one_of_two_nodes_shut_down": """
node, heard = make()
other = CustomNode("other_child", stop_func=lambda: say("STOP2"))
echo = threading.Event()
other.add_agent(conn_name="echo", conn_type="sub", data_interface=String,
                response_func=lambda _v: echo.set())
shout = other.add_agent(conn_name="echo", agent_name="shout", conn_type="pub",
                        data_interface=String, time_period=0.01, response_func=lambda: "hi")
node.spin(run_thread=True)
other.spin(run_thread=True)
ready(heard)
node.shutdown()  # the other node shares the context pyconnect initialised: it keeps working
echo.clear()
print("OTHER WORKS" if echo.wait(60) and other.context.ok() else "OTHER BROKEN", flush=True)
other.shutdown()
print("CONTEXT DOWN" if not other.context.ok() else "CONTEXT LEFT", flush=True)
""",
    "node_after_node": """
node, heard = make()
node.spin(run_thread=True)
ready(heard)
node.shutdown()
again = CustomNode("again_child", stop_func=lambda: say("STOP2"))  # a fresh default context
echo = threading.Event()
again.add_agent(conn_name="echo", conn_type="sub", data_interface=String,
                response_func=lambda _v: echo.set())
again.add_agent(conn_name="echo", agent_name="shout", conn_type="pub",
                data_interface=String, time_period=0.01, response_func=lambda: "hi")
again.spin(run_thread=True)
print("SECOND WORKS" if echo.wait(60) else "SECOND BROKEN", flush=True)
again.shutdown()
print("AFTER SECOND", flush=True)
""",
    "stop_service_blocking_spin": """
from std_srvs.srv import Trigger

node, heard = make()

def stop(_request):
    node.shutdown()  # in the handler: returns at once, the reply is sent, then the node ends
    return {"success": True, "message": "stopping"}

node.add_agent(conn_name="stop", conn_type="service_server", data_interface=Trigger,
               response_func=stop)
caller = CustomNode("stop_caller")
client = caller.add_agent(conn_name="stop", conn_type="service_client", data_interface=Trigger)
replies = []

def call():
    ready(heard)
    replies.append(client.send(timeout=60))

calling = threading.Thread(target=call, daemon=True)
calling.start()
node.spin()
calling.join(60)
print("REPLY", replies[0]["success"] if replies else "NONE", flush=True)
caller.shutdown()
print("AFTER SERVICE", flush=True)
""",
    "sys_exit_in_a_callback": """
import os

node, heard = make()
announced = threading.Event()

def finish():
    if announced.is_set():
        sys.exit("the task is done")  # in a handler: the node shuts down, spin() returns

node.add_agent(conn_name="finish", conn_type="timer", time_period=0.01, response_func=finish)

def announce():
    ready(heard)
    announced.set()

def watchdog():
    # Before the fix spin() never returned: fail instead of hanging the test.
    if not returned.wait(60):
        say("SPIN HUNG")
        os._exit(1)

returned = threading.Event()
threading.Thread(target=announce, daemon=True).start()
threading.Thread(target=watchdog, daemon=True).start()
node.spin()
returned.set()
print("AFTER EXIT", flush=True)
""",
    "sigterm_user_handler_exits": """
import signal

def save_state(_signum, _frame):
    say("USER HANDLER")  # installed before the node: pyconnect calls it after its own
    raise SystemExit(0)

signal.signal(signal.SIGTERM, save_state)
node, heard = make()
node.spin(run_thread=True)
try:  # the signal may come while READY is still being printed
    ready(heard)
    while True:
        time.sleep(0.05)
finally:
    say("FINALLY")
""",
    "sigterm_user_handler_exits_during_spin": """
import signal

def save_state(_signum, _frame):
    say("USER HANDLER")
    raise SystemExit(0)  # out of spin(): the shutdown already under way still completes

signal.signal(signal.SIGTERM, save_state)
node, heard = make()
threading.Thread(target=ready_when_main_waits, args=(node, heard), daemon=True).start()
node.spin()
say("SPIN RETURNED")
""",
    "sigterm_user_handler_returns": """
import signal

stopping = threading.Event()

def stop_loop(_signum, _frame):
    say("USER HANDLER")
    stopping.set()  # returns: the program's own loop ends, no SystemExit cuts it short

signal.signal(signal.SIGTERM, stop_loop)
node, heard = make()
node.spin(run_thread=True)
ready(heard)
while not stopping.is_set():
    time.sleep(0.05)
node.wait_for_shutdown()
print("AFTER LOOP", flush=True)
""",
    "sigint_user_handler_interrupts": """
import signal

def on_interrupt(_signum, _frame):
    say("USER HANDLER")
    raise KeyboardInterrupt

signal.signal(signal.SIGINT, on_interrupt)
node, heard = make()
node.spin(run_thread=True)
try:  # the signal may come while READY is still being printed
    ready(heard)
    while True:
        time.sleep(0.05)
except KeyboardInterrupt:
    say("INTERRUPTED")
node.wait_for_shutdown()
print("AFTER INTERRUPT", flush=True)
""",
    "interpreter_exit": """
node, heard = make()
node.spin(run_thread=True)
ready(heard)
print("END OF SCRIPT", flush=True)
""",
}

SIGNALS = {
    "sigint_async_handlers_busy": signal.SIGINT,
    "sigint_blocking_spin": signal.SIGINT,
    "sigint_thread_wait_for_shutdown": signal.SIGINT,
    "sigint_thread_user_loop": signal.SIGINT,
    "sigterm_thread_user_loop": signal.SIGTERM,
    "sigint_two_nodes": signal.SIGINT,
    "sigterm_user_handler_exits": signal.SIGTERM,
    "sigterm_user_handler_exits_during_spin": signal.SIGTERM,
    "sigterm_user_handler_returns": signal.SIGTERM,
    "sigint_user_handler_interrupts": signal.SIGINT,
}

# The program's own handler ran (besides the node's shutdown: STOP once).
USER_HANDLER = {
    "sigterm_user_handler_exits": ["USER HANDLER", "FINALLY"],
    "sigterm_user_handler_exits_during_spin": ["USER HANDLER"],
    "sigterm_user_handler_returns": ["USER HANDLER"],
    "sigint_user_handler_interrupts": ["USER HANDLER", "INTERRUPTED"],
}

LAST_LINE = {
    "sigint_async_handlers_busy": "AFTER BUSY",
    "sigint_blocking_spin": "AFTER SPIN",
    "sigint_thread_wait_for_shutdown": "AFTER WAIT",
    "shutdown_call": "AFTER SHUTDOWN",
    "with_block": "AFTER WITH",
    "sigint_two_nodes": "AFTER TWO",
    "one_of_two_nodes_shut_down": "CONTEXT DOWN",
    "node_after_node": "AFTER SECOND",
    "stop_service_blocking_spin": "AFTER SERVICE",
    "sys_exit_in_a_callback": "AFTER EXIT",
    "sigterm_user_handler_returns": "AFTER LOOP",
    "sigint_user_handler_interrupts": "AFTER INTERRUPT",
}


def run_child(
    source: str, tmp_path: Path, *, send: int | None = None, close_stderr: bool = False
) -> tuple[int, str, str]:
    """Run ``PRELUDE`` + ``source`` in a child Python, which prints ``READY`` first; send it
    ``send`` then; (exit code, stdout after READY, stderr). ``close_stderr`` starts it with
    file descriptor 2 closed (``2>&-``: ``sys.stderr`` is None), its stderr then reads ""."""
    script = tmp_path / "child.py"
    script.write_text(textwrap.dedent(PRELUDE) + textwrap.dedent(source))
    command = [sys.executable, str(script)]
    if close_stderr:  # by the shell: preexec_fn is unsafe in this multi-threaded process
        command = ["/bin/sh", "-c", 'exec "$0" "$@" 2>&-', *command]
    err_path = tmp_path / "stderr.txt"
    with err_path.open("w") as err_file:
        child = subprocess.Popen(
            command,
            stdout=subprocess.PIPE,
            stderr=err_file,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        try:
            assert child.stdout is not None
            first = child.stdout.readline().strip()
            assert first == "READY"
            if send is not None:
                child.send_signal(send)
            # Reads through the same buffered file as readline (communicate() would skip
            # what readline buffered already).
            out = child.stdout.read()
            child.wait(EVENT_TIMEOUT * 2)
        finally:
            if child.poll() is None:
                child.kill()
                child.wait()
            if child.stdout is not None:
                child.stdout.close()
    return child.returncode, out, err_path.read_text()


@pytest.mark.parametrize("ending", sorted(ENDINGS))
def test_program_ends_cleanly(ending: str, tmp_path: Path) -> None:
    returncode, out, err = run_child(ENDINGS[ending], tmp_path, send=SIGNALS.get(ending))
    lines = out.split()
    assert returncode == 0, err
    assert lines.count("STOP") == 1, (out, err)
    assert "terminate called" not in err
    assert "Traceback" not in err, err
    if ending in ("sigint_two_nodes", "one_of_two_nodes_shut_down", "node_after_node"):
        assert lines.count("STOP2") == 1, (out, err)
    assert "BROKEN" not in out
    if ending == "stop_service_blocking_spin":
        assert "REPLY True" in out, (out, err)
    for line in USER_HANDLER.get(ending, []):
        assert line in out.splitlines(), (out, err)
    if ending in LAST_LINE:
        assert out.strip().splitlines()[-1] == LAST_LINE[ending]
