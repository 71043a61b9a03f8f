"""erc-codec send and listen, end to end over 127.0.0.1, as two processes."""

import json
import socket
import subprocess
import sys


def start_listener(*args: str) -> tuple[subprocess.Popen[str], int]:
    listener = subprocess.Popen(
        [sys.executable, "-m", "erc_codec", "listen", "127.0.0.1:0", *args],
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
    sent = send(
        port, "driving_motor_message", '{"distance_to_go": 1.5}', "--count", "3", "--rate", "50"
    )
    assert sent.returncode == 0, sent.stderr
    assert "sent 3 datagram(s) of 7 bytes" in sent.stderr
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as raw:
        raw.sendto(b"\xb2\x01\x00", ("127.0.0.1", port))  # a member this schema lacks
    out, err = listener.communicate(timeout=30)
    assert listener.returncode == 0, err
    lines = [json.loads(line) for line in out.splitlines()]
    assert [line.get("kind", line.get("reason")) for line in lines] == [
        "driving_motor_message",
        "driving_motor_message",
        "driving_motor_message",
        "unknown_member",
    ]
    assert lines[0]["message"] == {"distance_to_go": 1.5, "turning_radius": 0.0}
    assert lines[0]["length"] == 7
    assert lines[0]["from"].startswith("127.0.0.1:")
    counters = json.loads(err.strip().splitlines()[-1].removeprefix("counters: "))
    assert counters == {
        "received": 4,
        "handled": {"driving_motor_message": 3},
        "undecodable": {"unknown_member": 1},
        "dropped": 1,
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
    from erc_codec.cli._net import resolve as _resolve
    from erc_codec.cli._net import shown as _shown

    family, address = _resolve("::1", 5005)
    assert family == socket.AF_INET6
    assert _shown(address) == "[::1]:5005"
    family, address = _resolve("127.0.0.1", 5005)
    assert family == socket.AF_INET
    assert _shown(address) == "127.0.0.1:5005"
    # A name with addresses of both families (from /etc/hosts, no server asked) takes IPv4.
    assert _resolve("localhost", 5005) == (socket.AF_INET, ("127.0.0.1", 5005))
