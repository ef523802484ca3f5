"""Slow and broken connections: a request head or body that stalls is cut off, logs get no raw control bytes."""

import json
import logging
import socket
import time

import pytest
from study_helpers import make_tiny_study

from antmaze_hirl.study import server as server_module
from antmaze_hirl.study.server import StudyServer

TOKEN = "connections-token-0123456789"


@pytest.fixture
def served(tmp_path, monkeypatch):
    monkeypatch.setattr(server_module, "HEADER_TIMEOUT_SECONDS", 0.5)
    monkeypatch.setattr(server_module, "BODY_CHUNK_TIMEOUT_SECONDS", 0.5)
    server = StudyServer(make_tiny_study(tmp_path / "study"), token=TOKEN)
    with server.running():
        yield server


def read_all(connection):
    chunks = []
    while chunk := connection.recv(65536):
        chunks.append(chunk)
    return b"".join(chunks).decode()


def test_a_request_head_that_never_ends_is_cut_off(served):
    with socket.create_connection(("127.0.0.1", served.port), timeout=30) as connection:
        connection.sendall(b"GET /api/study HTTP/1.1\r\nHost: 127.0.0.1\r\n")  # and never the blank line
        started = time.monotonic()
        assert read_all(connection) == ""  # closed by the server
        assert time.monotonic() - started < 10


def test_a_body_that_stalls_is_a_408_with_a_json_error(served):
    head = (
        f"POST /api/participants/P01/pause HTTP/1.1\r\nHost: 127.0.0.1:{served.port}\r\nX-Study-Token: {TOKEN}\r\n"
        "Content-Type: application/json\r\nContent-Length: 20\r\nConnection: close\r\n\r\n"
    )
    with socket.create_connection(("127.0.0.1", served.port), timeout=30) as connection:
        connection.sendall(head.encode() + b'{"pau')  # 5 of the 20 bytes, then nothing
        reply = read_all(connection)
    assert reply.startswith("HTTP/1.1 408") and '"error"' in reply and "stalled" in reply


def read_response(connection):
    """One HTTP response with a ``Content-Length`` from a kept-alive connection: its head and body."""
    data = b""
    while b"\r\n\r\n" not in data:
        data += connection.recv(65536)
    head, _, body = data.partition(b"\r\n\r\n")
    length = next(
        int(line.split(b":")[1]) for line in head.split(b"\r\n") if line.lower().startswith(b"content-length")
    )
    while len(body) < length:
        body += connection.recv(65536)
    return head.decode(), body


def test_each_answer_on_a_kept_alive_connection_comes_without_waiting_for_an_ack(served):
    # A response's head and body are two writes: under Nagle's algorithm on the server's connections the body
    # waited for the client's delayed ACK (about 40 ms), on every request after a connection's first.
    request = f"GET /api/study HTTP/1.1\r\nHost: 127.0.0.1:{served.port}\r\nX-Study-Token: {TOKEN}\r\n\r\n"
    seconds = []
    with socket.create_connection(("127.0.0.1", served.port), timeout=30) as connection:
        connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)  # the client's own writes go at once
        for _ in range(10):
            started = time.monotonic()
            connection.sendall(request.encode())
            head, body = read_response(connection)
            seconds.append(time.monotonic() - started)
            assert head.startswith("HTTP/1.1 200") and json.loads(body)
    assert min(seconds[1:]) < 0.02  # a delayed ACK would hold each of them 40 ms


def test_control_bytes_from_a_url_are_escaped_in_the_log(served, caplog):
    with caplog.at_level(logging.WARNING, logger="antmaze_hirl.study.server"):
        with socket.create_connection(("127.0.0.1", served.port), timeout=30) as connection:
            request = f"GET /api/x%1b[31mred HTTP/1.1\r\nHost: 127.0.0.1:{served.port}\r\nConnection: close\r\n\r\n"
            connection.sendall(request.encode())
            assert read_all(connection).startswith("HTTP/1.1 403")
    logged = "\n".join(record.getMessage() for record in caplog.records)
    assert "\\x1b[31mred" in logged and "\x1b" not in logged


MALFORMED = {
    "request line": b"GARBAGE\r\n\r\n",
    "header line": b"GET /api/study HTTP/1.1\r\nHost: 127.0.0.1\r\nno colon here\r\n\r\n",
    "content length": b"POST /api/study HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: abc\r\n\r\n",
    "head too large": b"GET /api/study HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: " + b"a" * 20_000,  # still unended
    "chunk size": (
        b"POST /api/participants/P01/pause HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Study-Token: "
        + TOKEN.encode()
        + b"\r\nTransfer-Encoding: chunked\r\n\r\nzz\r\n"
    ),
}


@pytest.mark.parametrize("request_bytes", MALFORMED.values(), ids=MALFORMED.keys())
def test_malformed_http_framing_is_a_json_400(served, request_bytes):
    with socket.create_connection(("127.0.0.1", served.port), timeout=30) as connection:
        connection.sendall(request_bytes)
        reply = read_all(connection)
    head, _, body = reply.partition("\r\n\r\n")
    assert head.startswith("HTTP/1.1 400"), reply[:200]
    assert "content-type: application/json" in head.lower() and "x-content-type-options: nosniff" in head.lower()
    assert json.loads(body)["error"].startswith("malformed HTTP request")
