"""``listen`` tells the truth live: rates over a sliding window that fall to 0, the age of each
kind, drops by reason as they happen, alerts for a silent kind; ``listen`` and ``send`` stopped by
SIGTERM or Ctrl-C print their counters and exit 0."""

import json
import signal
import socket
import subprocess
import sys
import time

import pytest
from datagrams import beside
from test_cli_net import start_listener

import erc_codec
from erc_codec.codec._unknown import MAX_UNKEPT_NUMBERS


def codec_datagram(kind: str) -> bytes:
    codec = erc_codec.Codec.default()
    return codec.encode(codec.message_class(kind)())


def test_watch_raises_an_alert_when_a_kind_goes_silent_and_when_it_is_back() -> None:
    listener, port = start_listener("--format", "json", "--watch", "gps_info=0.1")
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
        sender.sendto(codec_datagram("gps_info"), ("127.0.0.1", port))
        sent = time.monotonic()  # the listener's clock too: CLOCK_MONOTONIC is the system's
        time.sleep(1.0)  # three periods pass: silent
        alerted = time.monotonic()  # the alert was printed by now
        sender.sendto(codec_datagram("gps_info"), ("127.0.0.1", port))
        time.sleep(0.2)
    listener.send_signal(signal.SIGTERM)
    out, err = listener.communicate(timeout=30)
    assert listener.returncode == 0, err
    shown = [json.loads(line) for line in out.splitlines()]
    assert [r.get("alert", r.get("kind")) for r in shown[:4]] == [
        "gps_info",
        "silent",
        "back",
        "gps_info",
    ]
    assert shown[1]["kind"] == "gps_info"
    assert shown[1]["period"] == 0.1
    assert shown[1]["timeout"] == pytest.approx(0.3)  # three periods
    # Measured since the arrival (it was the timeout, 3 periods, whatever the clock said):
    # more than the timeout that passed, less than the time the test waited for it.
    assert 0.3 < shown[1]["silent_for"] < alerted - sent
    assert err.splitlines()[-1].startswith("counters: ")
    counters = json.loads(err.splitlines()[-1].removeprefix("counters: "))
    assert counters["handled"] == {"gps_info": 2}


def test_a_kind_is_watched_by_the_timeout_its_sender_advertises() -> None:
    """No --watch: the drive commands advertise 200 ms on the wire, and their silence is an
    alert all the same, with no period (nobody configured one) and the advertised timeout."""
    listener, port = start_listener("--format", "json")
    codec = erc_codec.Codec.default()
    drive = codec.encode(codec.message_class("DrivingBoardMotorMessage")(), timeout=200)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
        sender.sendto(drive, ("127.0.0.1", port))
        sender.sendto(codec_datagram("gps_info"), ("127.0.0.1", port))  # advertises none
        time.sleep(1.0)
    listener.send_signal(signal.SIGTERM)
    out, err = listener.communicate(timeout=30)
    assert listener.returncode == 0, err
    alerts = [record for line in out.splitlines() if "alert" in (record := json.loads(line))]
    assert [(a["alert"], a["kind"], a["period"]) for a in alerts] == [
        ("silent", "drive_motor", None)
    ]
    assert alerts[0]["timeout"] == pytest.approx(0.2)
    assert alerts[0]["silent_for"] >= 0.2


def test_an_unknown_watched_kind_or_period_is_a_usage_error() -> None:
    for watch, text in (("nope=1", "unknown kind 'nope'"), ("gps_info=0", "gps_info=0")):
        done = subprocess.run(
            [sys.executable, "-m", "erc_codec", "listen", "0", "--watch", watch],
            capture_output=True,
            text=True,
            check=False,
        )
        assert done.returncode == 2
        assert done.stderr.count("\n") == 1
        assert text in done.stderr


def test_the_table_shows_ages_watches_and_drops_by_reason() -> None:
    listener, port = start_listener("--format", "table", "--seconds", "3", "--watch", "ph_info=5")
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
        sender.sendto(codec_datagram("gps_info"), ("127.0.0.1", port))
        sender.sendto(b"\xb2\x01\x00", ("127.0.0.1", port))  # a member this schema lacks
    out, err = listener.communicate(timeout=30)
    assert listener.returncode == 0, err
    last = out[out.rindex("kind ") :].splitlines()  # the last drawing (click drops the escapes)
    assert last[0].split() == ["kind", "count", "rate", "Hz", "last", "seen", "watch"]
    gps = next(line for line in last if line.startswith("gps_info")).split()
    assert gps[:2] == ["gps_info", "1"]
    assert gps[4:] == ["s", "ago"]
    ph = next(line for line in last if line.startswith("ph_info")).split()
    assert ph[1:] == ["0", "0.0", "never", "waiting", "(every", "5", "s,", "timeout", "15", "s)"]
    assert "dropped: undecodable unknown_member: 1" in last


@pytest.mark.parametrize("number", [signal.SIGTERM, signal.SIGINT])
def test_send_stopped_by_a_signal_says_how_many_it_sent(number: signal.Signals) -> None:
    """Ctrl-C printed ``Aborted!`` and exit 1, with no count."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as receiver:
        receiver.bind(("127.0.0.1", 0))
        receiver.settimeout(60)
        target = f"127.0.0.1:{receiver.getsockname()[1]}"
        command = ["send", target, "gps_info", "{}", "--count", "100000", "--rate", "50"]
        sender = subprocess.Popen(
            [sys.executable, "-m", "erc_codec", *command], stderr=subprocess.PIPE, text=True
        )
        receiver.recv(64)  # it is sending
        sender.send_signal(number)
        assert sender.wait(timeout=30) == 0
    assert sender.stderr is not None
    line = sender.stderr.read()
    sender.stderr.close()
    assert line.startswith("sent ")
    assert line.endswith(f" of 100000 datagram(s) of 1 bytes to {target} (stopped by a signal)\n")


@pytest.mark.parametrize("number", [signal.SIGTERM, signal.SIGINT])
def test_listen_stopped_by_a_signal_prints_its_counters(number: signal.Signals) -> None:
    listener, port = start_listener("--format", "json")
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
        sender.sendto(codec_datagram("gps_info"), ("127.0.0.1", port))
    time.sleep(0.3)
    listener.send_signal(number)
    out, err = listener.communicate(timeout=30)
    assert listener.returncode == 0, err
    assert json.loads(out)["kind"] == "gps_info"
    counters = json.loads(err.splitlines()[-1].removeprefix("counters: "))
    assert counters["received"] == 1


def test_listen_counts_the_fields_beside_the_payload_in_a_table_of_bounded_size() -> None:
    """Ever new field numbers beside the payload: the counters list the first numbers to come,
    no more, and count every field of the others, once per datagram and number."""
    numbers = list(range(1000, 1000 + MAX_UNKEPT_NUMBERS + 100))
    rounds = [numbers[start : start + 50] for start in range(0, len(numbers), 50)]
    sent = [beside(numbers_of_one) for numbers_of_one in rounds * 2]
    listener, port = start_listener("--format", "json", "--count", str(len(sent)))
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender:
        for data in sent:
            sender.sendto(data, ("127.0.0.1", port))
            time.sleep(0.002)
    out, err = listener.communicate(timeout=30)
    assert listener.returncode == 0, err
    assert [json.loads(line)["kind"] for line in out.splitlines()] == ["gps_info"] * len(sent)
    counters = json.loads(err.splitlines()[-1].removeprefix("counters: "))
    assert counters["unkept"] == {str(number): 2 for number in numbers[:MAX_UNKEPT_NUMBERS]}
    assert counters["unkept_unlisted"] == 2 * 100


def test_send_takes_a_line_decode_printed() -> None:
    """``decode ... | encode gps_info -`` failed on decode's own "kind" key; send too."""
    line = subprocess.run(
        [sys.executable, "-m", "erc_codec", "decode", "620b09d8817346941e4a404802"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    listener, port = start_listener("--count", "1", "--seconds", "30", "--format", "json")
    sent = subprocess.run(
        [sys.executable, "-m", "erc_codec", "send", f"127.0.0.1:{port}", "gps_info", line],
        capture_output=True,
        text=True,
        check=False,
    )
    assert sent.returncode == 0, sent.stderr
    out, _ = listener.communicate(timeout=30)
    assert json.loads(out)["message"] == json.loads(line)["message"]
