"""erc-codec send and listen, end to end over 127.0.0.1, as two processes."""

import json
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

import erc_codec

# ``python -m erc_codec``, with Ctrl-C's handler restored first: a shell starting a job in the
# background (``pytest &``, nohup, some CI runners) ignores SIGINT, the child inherits that, and
# Python then installs no handler of its own: the SIGINT ending a listener would do nothing.
LISTEN = (
    "import runpy, signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
    "runpy.run_module('erc_codec', run_name='__main__')"
)


def start_listener(*args: str) -> tuple[subprocess.Popen[str], int]:
    listener = subprocess.Popen(
        [sys.executable, "-c", LISTEN, "listen", "127.0.0.1:0", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert listener.stderr is not None
    first = listener.stderr.readline()  # "listening on 127.0.0.1:PORT"
    assert first.startswith("listening on 127.0.0.1:"), first
    return listener, int(first.rsplit(":", 1)[1])


def send(port: int, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "erc_codec", "send", f"127.0.0.1:{port}", *args],
        capture_output=True,
        text=True,
        timeout=30,
    )


def test_send_to_listen() -> None:
    listener, port = start_listener("--count", "4", "--seconds", "30", "--format", "json")
    sent = send(port, "drive_motor", '{"distance_to_go": 1.5}', "--count", "3", "--rate", "50")
    assert sent.returncode == 0, sent.stderr
    assert "sent 3 datagram(s) of 7 bytes" in sent.stderr
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as raw:
        raw.sendto(b"\xb2\x01\x00", ("127.0.0.1", port))  # a member this schema lacks
    out, err = listener.communicate(timeout=30)
    assert listener.returncode == 0, err
    lines = [json.loads(line) for line in out.splitlines()]
    assert [line.get("kind", line.get("reason")) for line in lines] == [
        "drive_motor",
        "drive_motor",
        "drive_motor",
        "unknown_member",
    ]
    assert lines[0]["message"] == {"distance_to_go": 1.5, "turning_radius": 0.0}
    assert lines[0]["length"] == 7
    assert lines[0]["from"].startswith("127.0.0.1:")
    counters = json.loads(err.strip().splitlines()[-1].removeprefix("counters: "))
    assert counters.pop("receive_buffer") >= 2 * 212992  # at least what Linux grants by default
    assert counters == {
        "received": 4,
        "handled": {"drive_motor": 3},
        "undecodable": {"unknown_member": 1},
        "dropped": 1,
        "kernel_dropped": 0,
        "unread": 0,
    }


def test_listen_draws_a_table() -> None:
    listener, port = start_listener("--count", "5", "--seconds", "30", "--format", "table")
    send(port, "gps_info", '{"satellites": 9}', "--count", "5", "--rate", "20")
    out, err = listener.communicate(timeout=30)
    assert listener.returncode == 0
    assert "gps_info" in out
    assert '"received": 5' in err


def test_send_refuses_what_a_board_would_drop() -> None:
    done = send(9, "gps_info", '{"fix_quality": 9}')
    assert done.returncode == 1
    assert "fix_quality: 9 is not a declared value: GPSFixQuality takes one of" in done.stderr
    assert done.stderr.count("\n") == 1


def test_bad_addresses_are_usage_errors() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "erc_codec", "send", "nowhere", "gps_info", "{}"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2
    assert "expected HOST:PORT" in done.stderr
    done = subprocess.run(
        [sys.executable, "-m", "erc_codec", "send", "[]:5005", "gps_info", "{}"],
        capture_output=True,
        text=True,
    )
    assert (done.returncode, done.stderr) == (
        2,
        "Error: Invalid value: '[]:5005': expected HOST:PORT\n",
    )
    # A name that cannot be a host name fails in the resolver, without asking any server.
    done = subprocess.run(
        [sys.executable, "-m", "erc_codec", "send", "a..b:5005", "gps_info", "{}"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2
    assert done.stderr.startswith("Error: cannot resolve 'a..b'")
    assert done.stderr.count("\n") == 1


def test_listen_stops_after_its_time() -> None:
    listener, _ = start_listener("--seconds", "0.3")
    out, err = listener.communicate(timeout=30)
    assert (listener.returncode, out) == (0, "")
    assert '"received": 0' in err


def test_addresses_of_either_family_resolve_and_show_their_port() -> None:
    from erc_codec.cli._shared import resolve as _resolve
    from erc_codec.cli._shared import shown as _shown

    family, address = _resolve("::1", 5005)
    assert family == socket.AF_INET6
    assert _shown(address) == "[::1]:5005"
    family, address = _resolve("127.0.0.1", 5005)
    assert family == socket.AF_INET
    assert _shown(address) == "127.0.0.1:5005"
    # A name with addresses of both families (from /etc/hosts, no server asked) takes IPv4.
    assert _resolve("localhost", 5005) == (socket.AF_INET, ("127.0.0.1", 5005))


def rcvbuf_errors() -> int:
    """Every UDP socket's receive-buffer drops on this machine (``/proc/net/snmp``)."""
    lines = Path("/proc/net/snmp").read_text().splitlines()
    names, values = (line.split()[1:] for line in lines if line.startswith("Udp:"))
    return int(dict(zip(names, values, strict=True))["RcvbufErrors"])


@pytest.mark.skipif(sys.platform != "linux", reason="the kernel's drop count is Linux's")
def test_listen_counts_what_the_kernel_dropped() -> None:
    listener, port = start_listener("--format", "json")
    codec = erc_codec.Codec.default()
    data = codec.encode(codec.message_class("DrivingBoardMotorMessage")(distance_to_go=1.0))
    sent = 40_000  # more than its receive buffer holds (8 MiB hold some 10,000 such datagrams)
    try:
        before = rcvbuf_errors()
        listener.send_signal(signal.SIGSTOP)  # its reader paused: the kernel queues, then drops
        try:
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as raw:
                for _ in range(sent):
                    raw.sendto(data, ("127.0.0.1", port))
        finally:
            listener.send_signal(signal.SIGCONT)
        after = rcvbuf_errors()
        deadline = time.monotonic() + 20
        assert listener.stdout is not None
        shown = 0
        while time.monotonic() < deadline and listener.stdout.readline():
            shown += 1  # a line per datagram that was queued
            if shown + (after - before) >= sent:
                break
        time.sleep(0.2)
        listener.send_signal(signal.SIGINT)
        out, err = listener.communicate(timeout=30)
    finally:  # a failure above must not leave the listener running
        if listener.poll() is None:
            listener.kill()
            listener.communicate()
    shown += len(out.splitlines())
    counters = json.loads(err.strip().splitlines()[-1].removeprefix("counters: "))
    assert counters["received"] == shown
    assert counters["received"] + counters["kernel_dropped"] + counters["unread"] == sent
    assert counters["kernel_dropped"] > 0
    assert after - before >= counters["kernel_dropped"]  # the system saw them too


@pytest.mark.parametrize(
    ("command", "option", "value", "problem"),
    [
        ("listen", "--seconds", "nan", "'nan' is not a finite number."),
        ("listen", "--seconds", "inf", "'inf' is not a finite number."),
        ("listen", "--seconds", "-1", "-1.0 is not in the range x>0."),
        ("listen", "--seconds", "0", "0.0 is not in the range x>0."),
        ("listen", "--count", "0", "0 is not in the range x>=1."),
        ("listen", "--count", "nan", "'nan' is not a valid integer range."),
        ("send", "--rate", "nan", "'nan' is not a finite number."),
        ("send", "--rate", "-inf", "-inf is not in the range x>0."),
        ("send", "--rate", "0", "0.0 is not in the range x>0."),
        ("send", "--count", "1.5", "'1.5' is not a valid integer range."),
    ],
)
def test_times_rates_and_counts_that_are_not_finite_and_positive_are_usage_errors(
    command: str, option: str, value: str, problem: str
) -> None:
    target = ["127.0.0.1:0"] if command == "listen" else ["127.0.0.1:9", "gps_info", "{}"]
    done = subprocess.run(
        [sys.executable, "-m", "erc_codec", command, *target, option, value],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert (done.returncode, done.stdout) == (2, "")
    assert done.stderr == f"Error: Invalid value for '{option}': {problem}\n"


SLOWEST = ["--rate", "1e-300", "--count", "2"]


def test_send_at_a_rate_slower_than_time_can_sleep_waits_instead_of_failing() -> None:
    sender = subprocess.Popen(
        [sys.executable, "-m", "erc_codec", "send", "127.0.0.1:9", "gps_info", "{}", *SLOWEST],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        with pytest.raises(subprocess.TimeoutExpired):  # the second send is due in 1e300 s
            sender.wait(timeout=1.5)
    finally:
        sender.kill()
        _, err = sender.communicate()
    assert "Traceback" not in err


def test_listen_ends_when_its_reader_goes_away() -> None:
    listener, port = start_listener("--format", "json")
    assert listener.stdout is not None
    listener.stdout.close()  # as `listen | head -1` does once it has its line
    try:
        for _ in range(5):
            send(port, "gps_info", "{}", "--count", "3")
            if listener.poll() is not None:
                break
        assert listener.wait(timeout=10) == 1  # quietly: the reader went away
    finally:
        listener.kill()
        _, err = listener.communicate()
    assert "Traceback" not in err
    assert "counters:" not in err


def test_send_takes_a_decoded_line_on_standard_input() -> None:
    datagram = "62024003f001ac02"  # gps_info, satellites 3, with the envelope's timeout
    line = subprocess.run(
        [sys.executable, "-m", "erc_codec", "decode", datagram],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as receiver:
        receiver.bind(("127.0.0.1", 0))
        receiver.settimeout(10)
        port = receiver.getsockname()[1]
        done = subprocess.run(
            [sys.executable, "-m", "erc_codec", "send", f"127.0.0.1:{port}", "gps_info", "-"],
            input=line,
            capture_output=True,
            text=True,
            check=False,
        )
        assert done.returncode == 0, done.stderr
        assert receiver.recv(4096).hex() == datagram
