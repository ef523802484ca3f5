"""The study's web app: a FastAPI app on uvicorn that serves the page and its JSON API.

Security follows the Jupyter server's model: it binds the loopback interface by default, every API
request and the page itself need the random token printed in the start-up URL (``?token=``, or the
``X-Study-Token`` header), and requests with a foreign ``Host`` header (DNS rebinding) or a cross-site
``Origin`` are refused. Bodies are JSON objects of at most :data:`MAX_BODY_BYTES` (counted while the
body streams in, so a chunked body is cut off, not read whole), nested at most :data:`MAX_JSON_DEPTH`
deep, with only the fields the route names. Every response carries ``X-Content-Type-Options: nosniff``,
a ``Content-Security-Policy`` with ``frame-ancestors 'self'`` and ``Referrer-Policy: no-referrer`` (the
URL holds the token); the page and the API also ``Cache-Control: no-store``. Refused requests are
logged as warnings (logger ``antmaze_hirl.study.server``), without the token. One server per study
folder: :class:`~antmaze_hirl.study.store.StudyLock` holds an OS lock on ``DIR/server.lock``.

API (all under ``/api``, JSON in and out; errors, unknown paths and methods included, are
``{"error": "..."}`` with a 4xx status; a participant whose files are damaged gets 409 naming the file):

* ``GET /api/study``: body, participants and where each one is;
* ``GET /api/questionnaire``: the questionnaire items;
* ``GET /api/participants/{id}/state``: what the page shows;
* ``POST /api/participants/{id}/start`` ``{}``: start the next trial;
* ``POST /api/participants/{id}/label`` ``{"query", "x", "y", "response_seconds"}``: a click;
* ``POST /api/participants/{id}/next`` ``{}``: after a click that ended an episode, close it (the learner's
  update) and open the next maze; the page sends it while it animates the last walk;
* ``POST /api/participants/{id}/questionnaire`` ``{"trial", "ratings", "comment"}``;
* ``POST /api/participants/{id}/pause`` ``{"paused": true|false}``;
* ``GET /api/participants/{id}/frame.png``: the ant's camera view, where OpenGL rendering works.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import json
import logging
import os
import secrets
import socket
import sys
import threading
import time
from collections.abc import Awaitable, Callable, Iterator, Sequence
from importlib import resources
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException
from starlette.requests import ClientDisconnect

from antmaze_hirl.study.camera import CameraUnavailable
from antmaze_hirl.study.questionnaire import SCALE_MAX, TLX_ITEMS
from antmaze_hirl.study.session import BadInput, DamagedRecords, ProtocolError
from antmaze_hirl.study.store import Study, StudyLock, UnknownParticipant

MAX_BODY_BYTES = 16_384
"""Largest request body accepted (a click or a questionnaire is far smaller)."""

MAX_JSON_DEPTH = 8
"""Deepest nesting of objects and arrays accepted in a body (a questionnaire needs 2)."""

HEADER_TIMEOUT_SECONDS = 10.0
"""A connection that has not sent a whole request head this long after it opened is closed (no slowloris)."""

BODY_CHUNK_TIMEOUT_SECONDS = 10.0
"""Longest wait for the next piece of a request body; longer is a 408 (a slow body is cut off)."""

KEEP_ALIVE_SECONDS = 5
"""An idle keep-alive connection is closed after this long."""

MAX_CONNECTIONS = 64
"""Connections and requests served at once; more are answered 503 by uvicorn."""

MAX_HEADER_BYTES = 16_384
"""Largest request head (request line and headers) h11 buffers; more is a 400 from h11."""

MIN_TOKEN_CHARS = 16
"""Shortest token accepted (a random one has 32 characters)."""

TOKEN_ENV = "ANTMAZE_HIRL_STUDY_TOKEN"
"""Environment variable the token is read from when no ``--token`` is given (not visible in ``ps``)."""

LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1")
TOKEN_HEADER = "X-Study-Token"

SECURITY_HEADERS = {
    "X-Content-Type-Options": "nosniff",
    "Content-Security-Policy": (
        "default-src 'self'; img-src 'self' data:; object-src 'none'; base-uri 'none'; form-action 'self'; "
        "frame-ancestors 'self'"
    ),
    "Referrer-Policy": "no-referrer",
}
"""Headers on every response (as the Jupyter server sends them)."""

ROUTE_FIELDS = {
    "start": frozenset(),
    "next": frozenset(),
    "pause": frozenset({"paused"}),
    "label": frozenset({"query", "x", "y", "response_seconds"}),
    "questionnaire": frozenset({"trial", "ratings", "comment"}),
}
"""The fields each POST route accepts; any other is refused."""

logger = logging.getLogger(__name__)


class BodyTooLarge(BadInput):
    """A request body over :data:`MAX_BODY_BYTES` (answered with HTTP 413)."""


class BodyTimeout(BadInput):
    """A request body that stalls for :data:`BODY_CHUNK_TIMEOUT_SECONDS` (answered with HTTP 408)."""


def printable(text: str, limit: int = 300) -> str:
    """``text`` with control and other unprintable characters escaped as ``ascii()`` does, cut: safe to log."""
    return "".join(char if char.isprintable() else ascii(char)[1:-1] for char in text[:limit])


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a number JSON allows")


def parse_json_object(body: bytes) -> dict[str, Any]:
    """A request body as a JSON object.

    Raises:
        BadInput: If the body is too large, not UTF-8 JSON (``NaN``/``Infinity`` included), or not an object.
    """
    if len(body) > MAX_BODY_BYTES:
        raise BodyTooLarge(f"request body of {len(body)} bytes is larger than {MAX_BODY_BYTES}")
    try:
        text = body.decode("utf-8")
        depth = _nesting_depth(text)
        if depth > MAX_JSON_DEPTH:
            raise BadInput(f"request body is nested more than {MAX_JSON_DEPTH} deep")
        payload = json.loads(text, parse_constant=_reject_constant)
    except (UnicodeDecodeError, ValueError, RecursionError) as error:
        if isinstance(error, BadInput):
            raise
        # ValueError covers integers of more than sys.get_int_max_str_digits() digits too
        raise BadInput(f"request body is not valid JSON: {str(error)[:200]}") from None
    if not isinstance(payload, dict):
        raise BadInput(f"request body must be a JSON object, got {type(payload).__name__}")
    return payload


def _nesting_depth(text: str, stop: int = MAX_JSON_DEPTH) -> int:
    """How deep ``[`` and ``{`` nest in JSON ``text`` (outside strings), counted up to ``stop + 1``."""
    depth = deepest = 0
    in_string = escaped = False
    for char in text:
        if in_string:
            if escaped:
                escaped = False
            elif char == "\\":
                escaped = True
            elif char == '"':
                in_string = False
        elif char == '"':
            in_string = True
        elif char in "[{":
            depth += 1
            if depth > deepest:
                deepest = depth
                if deepest > stop:
                    break
        elif char in "]}":
            depth -= 1
    return deepest


async def read_body(request: Request, limit: int = MAX_BODY_BYTES, chunk_timeout: float | None = None) -> bytes:
    """The request's body, read chunk by chunk and refused as soon as it passes ``limit`` bytes.

    Raises:
        BodyTooLarge: Without reading the rest (a chunked body has no Content-Length to check first).
        BodyTimeout: If the next chunk takes more than ``chunk_timeout`` seconds (default
            :data:`BODY_CHUNK_TIMEOUT_SECONDS`).
    """
    if chunk_timeout is None:
        chunk_timeout = BODY_CHUNK_TIMEOUT_SECONDS
    chunks, size = [], 0
    stream = request.stream()
    while True:
        try:
            chunk = await asyncio.wait_for(anext(stream), chunk_timeout)
        except StopAsyncIteration:
            break
        except TimeoutError:
            raise BodyTimeout(f"request body stalled for {chunk_timeout:g} s") from None
        size += len(chunk)
        if size > limit:
            raise BodyTooLarge(f"request body of more than {limit} bytes is larger than {limit}")
        chunks.append(chunk)
    return b"".join(chunks)


def check_fields(payload: dict[str, Any], route: str) -> dict[str, Any]:
    """``payload``, if it has only the fields :data:`ROUTE_FIELDS` allows for ``route``.

    Raises:
        BadInput: Naming the unknown fields.
    """
    unknown = sorted(set(payload) - ROUTE_FIELDS[route], key=str)
    if unknown:
        allowed = sorted(ROUTE_FIELDS[route]) or "none"
        raise BadInput(f"unknown field(s) {unknown[:5]} in a {route} request (allowed: {allowed})"[:300])
    return payload


def check_token(token: str) -> str:
    """``token`` if it is long enough to guess at no better than chance.

    Raises:
        ValueError: If it is shorter than :data:`MIN_TOKEN_CHARS` characters.
    """
    if len(token) < MIN_TOKEN_CHARS:
        raise ValueError(f"the study token must have at least {MIN_TOKEN_CHARS} characters, got {len(token)}")
    return token


def _host_name(netloc: str) -> str:
    # "127.0.0.1:8765" -> "127.0.0.1", "[::1]:8765" -> "::1", "localhost" -> "localhost"; "[::1" -> "" (refused)
    try:
        return (urlsplit(f"//{netloc}").hostname or "").lower()
    except ValueError:  # an unbalanced "[" or a bad port
        return ""


def _origin_netloc(origin: str) -> str | None:
    # The Origin's host:port, or None for one that is not a URL (refused as cross-site).
    try:
        return urlsplit(origin).netloc.lower()
    except ValueError:
        return None


def create_app(study: Study, *, token: str, allowed_hosts: Sequence[str] = LOOPBACK_HOSTS) -> Any:
    """The FastAPI app serving ``study``.

    Args:
        study: The opened study folder.
        token: Secret every request to the page or the API must carry.
        allowed_hosts: Host names accepted in the ``Host`` header (and as same-site ``Origin``).
    """
    check_token(token)
    hosts = {host.lower().strip("[]") for host in allowed_hosts}
    static = resources.files("antmaze_hirl.study") / "static"
    app = FastAPI(title="antmaze_hirl study", docs_url=None, redoc_url=None, openapi_url=None)
    app.state.study = study

    def refuse(request: Request, status: int, message: str) -> Any:
        client = request.client.host if request.client else "?"
        path, shown = printable(request.url.path), printable(message)  # no escape bytes from a URL reach a console
        logger.warning("refused %s %s from %s: %d %s", printable(request.method), path, client, status, shown)
        return JSONResponse({"error": message}, status_code=status)

    def disconnected(request: Request, exc: ClientDisconnect) -> Any:
        # The client went away mid-body: nothing to answer and nothing wrong on this side, so no traceback.
        logger.warning("client left during %s %s", printable(request.method), printable(request.url.path))
        return Response(status_code=400)

    def failed(request: Request, exc: Exception) -> Any:
        # A bug: JSON like every other answer; the traceback goes to the server's log, not to the page.
        logger.error("error serving %s %s", printable(request.method), printable(request.url.path), exc_info=exc)
        return JSONResponse({"error": "internal error: the experimenter can find it in the server's log"}, 500)

    app.add_exception_handler(ClientDisconnect, disconnected)
    app.add_exception_handler(Exception, failed)
    statuses = {
        BodyTooLarge: 413,
        BodyTimeout: 408,
        BadInput: 400,
        ProtocolError: 409,
        DamagedRecords: 409,
        UnknownParticipant: 404,
    }
    for kind, status in statuses.items():
        app.add_exception_handler(kind, lambda request, exc, status=status: refuse(request, status, str(exc)))

    def unsaved(request: Request, exc: OSError) -> Any:
        # A write that failed (a full disk): the session changed nothing, so the page may simply try again.
        logger.error("could not save for %s %s: %s", request.method, request.url.path, exc)
        reason = exc.strerror or type(exc).__name__
        message = f"the server could not save ({reason}): nothing was changed; try again once the disk has room"
        return JSONResponse({"error": message}, status_code=503)

    app.add_exception_handler(OSError, unsaved)
    app.add_exception_handler(
        HTTPException,
        lambda request, exc: refuse(request, exc.status_code, str(exc.detail)),  # 404, 405
    )

    @app.middleware("http")
    async def guard(request: Request, call_next: Callable[[Request], Awaitable[Any]]) -> Any:
        started = time.perf_counter()
        response = _check_request(request)
        if response is None:
            response = await call_next(request)
            # The server's own time, apart from the network and the browser (benchmarks/study_latency.py reads it).
            response.headers["Server-Timing"] = f"app;dur={(time.perf_counter() - started) * 1000:.1f}"
        response.headers.update(SECURITY_HEADERS)
        if request.url.path == "/" or request.url.path.startswith("/api/"):
            response.headers["Cache-Control"] = "no-store"
        return response

    def _check_request(request: Request) -> Any:
        host = request.headers.get("host", "")
        if _host_name(host) not in hosts:
            return refuse(request, 403, f"Host header {host!r} is not allowed (allowed: {sorted(hosts)})")
        origin = request.headers.get("origin")
        if origin is not None and _origin_netloc(origin) != host.lower():
            return refuse(request, 403, f"cross-site request from Origin {origin!r} refused")
        path = request.url.path
        if path == "/" or path.startswith("/api/"):
            given = request.headers.get(TOKEN_HEADER) or request.query_params.get("token") or ""
            if not hmac.compare_digest(given.encode(), token.encode()):
                if path == "/":
                    refuse(request, 403, "missing or wrong token on the page")
                    return HTMLResponse(
                        "<h1>403</h1><p>Open the study with the URL the server printed (it ends with ?token=...).</p>",
                        status_code=403,
                    )
                return refuse(request, 403, "missing or wrong token: use the URL the server printed")
        length = request.headers.get("content-length")
        if length is not None and (not length.isdigit() or int(length) > MAX_BODY_BYTES):
            return refuse(request, 413, f"request body of {length[:20]} bytes is larger than {MAX_BODY_BYTES}")
        return None

    async def body_of(request: Request, route: str) -> dict[str, Any]:
        return check_fields(parse_json_object(await read_body(request)), route)

    async def session_of(participant_id: str) -> Any:
        # Restoring a session builds simulators and reads a checkpoint (seconds): off the event loop.
        return await run_in_threadpool(study.session, participant_id)

    @app.get("/")
    async def page() -> Any:
        return HTMLResponse((static / "index.html").read_text(encoding="utf-8"))

    @app.get("/favicon.ico")
    async def favicon() -> Any:
        return Response(status_code=204)  # browsers ask for one; no warning in the log for it

    @app.get("/api/study")
    async def study_overview() -> Any:
        # From the saved progress: the participant picker must not build every participant's simulators.
        participants = []
        for participant in study.plan.participants:
            entry: dict[str, Any] = {"id": participant.id}
            try:
                index, phase = study.progress(participant.id)
            except (ValueError, OSError, DamagedRecords) as damaged:  # one participant's damage is theirs alone
                entry.update(phase="damaged", trial=None, error=str(damaged))
            else:
                number = index + 1 if index < len(participant.trials) else None  # None once every trial is done
                entry.update(phase=phase, trial=number)
            participants.append(entry)
        return {"body": study.plan.body, "participants": participants}

    @app.get("/api/questionnaire")
    async def questionnaire() -> Any:
        items = [
            {
                "key": item.key,
                "title": item.title,
                "question": item.question,
                "low": item.low_anchor,
                "high": item.high_anchor,
                "points": SCALE_MAX,
            }
            for item in TLX_ITEMS
        ]
        return {"items": items}

    @app.get("/api/participants/{participant_id}/state")
    async def state(participant_id: str) -> Any:
        return await run_in_threadpool((await session_of(participant_id)).state)

    def session_action(route: str, method: str) -> None:
        # POST .../{route}: an empty body (checked all the same), then the session's method with no arguments.
        async def act(participant_id: str, request: Request) -> Any:
            await body_of(request, route)
            return await run_in_threadpool(getattr(await session_of(participant_id), method))

        app.post(f"/api/participants/{{participant_id}}/{route}", name=method)(act)

    for route, method in (("start", "start_trial"), ("next", "next_episode")):
        session_action(route, method)

    @app.post("/api/participants/{participant_id}/label")
    async def label(participant_id: str, request: Request) -> Any:
        payload = await body_of(request, "label")
        session = await session_of(participant_id)
        return await run_in_threadpool(
            session.label, payload.get("query"), payload.get("x"), payload.get("y"), payload.get("response_seconds")
        )

    @app.post("/api/participants/{participant_id}/questionnaire")
    async def answers(participant_id: str, request: Request) -> Any:
        payload = await body_of(request, "questionnaire")
        trial = payload.pop("trial", None)
        session = await session_of(participant_id)
        return await run_in_threadpool(session.submit_questionnaire, trial, payload)

    @app.post("/api/participants/{participant_id}/pause")
    async def pause(participant_id: str, request: Request) -> Any:
        payload = await body_of(request, "pause")
        return await run_in_threadpool((await session_of(participant_id)).set_paused, payload.get("paused"))

    @app.get("/api/participants/{participant_id}/frame.png")
    async def frame(participant_id: str, request: Request) -> Any:
        session = await session_of(participant_id)
        try:
            png = await run_in_threadpool(session.camera_frame)
        except CameraUnavailable as missing:
            return refuse(request, 404, str(missing))
        return Response(png, media_type="image/png", headers={"Cache-Control": "no-store"})

    app.mount("/static", StaticFiles(directory=str(static)), name="static")
    return app


def uvicorn_config(app: Any) -> Any:
    """Uvicorn's settings for the study app: the timeouts and limits above, a request-head deadline."""
    import uvicorn

    return uvicorn.Config(
        app,
        log_level="warning",
        lifespan="off",
        http=_header_deadline_protocol(),
        timeout_keep_alive=KEEP_ALIVE_SECONDS,
        limit_concurrency=MAX_CONNECTIONS,
        h11_max_incomplete_event_size=MAX_HEADER_BYTES,
    )


def _header_deadline_protocol() -> type:
    # uvicorn times out idle keep-alive connections only after a response: a connection that never finishes
    # its first request head would be held for ever. This closes it HEADER_TIMEOUT_SECONDS after it opened,
    # and answers what h11 cannot parse with a JSON 400 (uvicorn's own is plain text).
    from uvicorn.protocols.http.h11_impl import H11Protocol

    class HeaderDeadlineH11Protocol(H11Protocol):
        def connection_made(self, transport: Any) -> None:  # type: ignore[override]
            super().connection_made(transport)
            self._head_deadline = self.loop.call_later(HEADER_TIMEOUT_SECONDS, self._head_overdue)

        def _head_overdue(self) -> None:
            if self.cycle is None and not self.transport.is_closing():  # no whole request head yet
                logger.warning("closed a connection that sent no request head in %g s", HEADER_TIMEOUT_SECONDS)
                self.transport.close()

        def connection_lost(self, exc: Exception | None) -> None:
            self._head_deadline.cancel()
            super().connection_lost(exc)

        def send_400_response(self, msg: str) -> None:
            # h11 could not parse the request (a bad request line or header, a head over MAX_HEADER_BYTES, bad
            # framing of the body): uvicorn answers before the app sees it, in plain text; JSON, as the app does.
            import h11

            body = json.dumps({"error": f"malformed HTTP request: {msg}"}).encode()
            headers = [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(body)).encode()),
                (b"connection", b"close"),
                (b"cache-control", b"no-store"),
                *((name.lower().encode(), value.encode()) for name, value in SECURITY_HEADERS.items()),
            ]
            try:
                for event in (h11.Response(status_code=400, headers=headers), h11.Data(data=body), h11.EndOfMessage()):
                    self.transport.write(self.conn.send(event))
            except h11.LocalProtocolError:  # the app had begun its answer already: nothing more can be said
                pass
            self.transport.close()

    return HeaderDeadlineH11Protocol


def new_token() -> str:
    """A random URL-safe token (Jupyter-style)."""
    return secrets.token_urlsafe(24)


def bind_socket(host: str, port: int) -> socket.socket:
    """A listening TCP socket on ``host:port`` (port 0: a free one), handed to uvicorn so no other process races for it.

    Raises:
        OSError: If the address is taken or invalid (names it).
    """
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    # IPPROTO_TCP named, not left 0: asyncio turns Nagle's algorithm off (TCP_NODELAY) only on the connections of a
    # socket whose protocol says TCP. Under Nagle a response's body, written after its head, waited for the
    # client's delayed ACK: about 40 ms on every request after a connection's first.
    sock = socket.socket(family, socket.SOCK_STREAM, socket.IPPROTO_TCP)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except OSError as error:
        sock.close()
        raise OSError(f"cannot listen on {host}:{port}: {error.strerror}") from error
    sock.listen(128)
    sock.set_inheritable(True)
    return sock


def study_url(host: str, port: int, token: str) -> str:
    """The URL a participant's browser opens."""
    shown = f"[{host}]" if ":" in host else host
    return f"http://{shown}:{port}/?token={token}"


class StudyServer:
    """Runs the app on uvicorn in a background thread (for ``study simulate``, tests and benchmarks).

    Args:
        study_dir: The study folder.
        host: Interface to bind (loopback by default).
        port: TCP port; 0 picks a free one.
        token: The token; a random one by default.

    Raises:
        StudyInUse: If another server holds the folder's lock (names its PID).
        ValueError: If the token is shorter than :data:`MIN_TOKEN_CHARS`.
    """

    def __init__(self, study_dir: str | Path, *, host: str = "127.0.0.1", port: int = 0, token: str | None = None):
        import uvicorn

        self.token = check_token(token or new_token())
        self.lock = StudyLock(study_dir)
        try:
            self.study = Study(study_dir)
            self.host = host
            self.socket = bind_socket(host, port)
        except BaseException:
            self.lock.release()
            raise
        self.port = int(self.socket.getsockname()[1])
        url_host, hosts = url_host_and_allowed(host)
        self._url_host = url_host
        app = create_app(self.study, token=self.token, allowed_hosts=hosts)
        self._server = uvicorn.Server(uvicorn_config(app))
        self._thread = threading.Thread(target=self._server.run, kwargs={"sockets": [self.socket]}, daemon=True)

    @property
    def url(self) -> str:
        """The participant's URL, token included."""
        return study_url(self._url_host, self.port, self.token)

    @property
    def base_url(self) -> str:
        """``http://host:port`` without the token."""
        return self.url.split("/?", 1)[0]

    def start(self) -> StudyServer:
        """Starts serving; returns once uvicorn accepts connections."""
        self._thread.start()
        self.study.resume_closing()
        while not self._server.started:
            if not self._thread.is_alive():
                raise RuntimeError("the study server stopped during start-up")
            self._thread.join(0.02)
        return self

    def stop(self) -> None:
        """Stops serving, waits for the closed trials' final updates to be written, releases the simulators and lock.

        (Its callers read the files next; ``study serve`` stops at once instead, and its next start resumes them.)
        """
        self._server.should_exit = True
        if self._thread.is_alive():
            self._thread.join(10)
        self.socket.close()
        try:
            self.study.wait_for_closed_trials()
        except RuntimeError as error:  # already logged; the next start runs it again
            logger.warning("%s", error)
        finally:
            self.study.close()
            self.lock.release()

    @contextlib.contextmanager
    def running(self) -> Iterator[StudyServer]:
        """``with server.running():`` serves for the block."""
        self.start()
        try:
            yield self
        finally:
            self.stop()


_WILDCARD_HOSTS = ("0.0.0.0", "::", "")


def url_host_and_allowed(host: str) -> tuple[str, list[str]]:
    """The host name to print in the URL for a server bound to ``host``, and the ``Host`` names to accept.

    Loopback names are always accepted. A specific address is accepted as itself. A wildcard address
    (``0.0.0.0``, ``::``) is no address a browser can open, so the URL names this machine
    (``socket.gethostname()``), and its name, full name and addresses are accepted.
    """
    hosts = list(LOOPBACK_HOSTS)
    if host not in _WILDCARD_HOSTS:
        if host not in hosts:
            hosts.append(host)
        return host, hosts
    name = socket.gethostname()
    names = {name, socket.getfqdn()}
    with contextlib.suppress(OSError):
        for found in (name, socket.getfqdn()):
            _, aliases, addresses = socket.gethostbyname_ex(found)
            names.update(aliases)
            names.update(addresses)
    hosts.extend(sorted(candidate.lower() for candidate in names if candidate and candidate.lower() not in hosts))
    return name, hosts


def allowed_hosts_for(host: str) -> list[str]:
    """Host names the ``Host`` header may carry for a server bound to ``host`` (see :func:`url_host_and_allowed`)."""
    return url_host_and_allowed(host)[1]


def resolve_token(token: str | None) -> str:
    """The token to serve with: ``token``, else :data:`TOKEN_ENV`, else a new random one.

    Raises:
        ValueError: If the one given is shorter than :data:`MIN_TOKEN_CHARS`.
    """
    chosen = token if token is not None else os.environ.get(TOKEN_ENV) or None
    return check_token(chosen) if chosen is not None else new_token()


def serve(
    study_dir: str | Path,
    *,
    host: str = "127.0.0.1",
    port: int = 8765,
    token: str | None = None,
    extra_hosts: Sequence[str] = (),
) -> None:
    """Serves a study until interrupted (``antmaze-hirl study serve``), printing the participants' URL.

    Raises:
        StudyInUse: If another server holds the folder (names its PID).
        ValueError: If the token (given, or from :data:`TOKEN_ENV`) is too short.
        OSError: If the address cannot be bound.
    """
    import uvicorn

    token = resolve_token(token)
    lock = StudyLock(study_dir)
    try:
        study = Study(study_dir)
        if host not in LOOPBACK_HOSTS:
            print(
                f"warning: serving on {host}, not loopback: anyone who can reach this machine and knows the token "
                "can use the study",
                file=sys.stderr,
            )
        sock = bind_socket(host, port)
    except BaseException:
        lock.release()
        raise
    port = int(sock.getsockname()[1])  # the one picked, when port 0 asked for any
    url_host, hosts = url_host_and_allowed(host)
    app = create_app(study, token=token, allowed_hosts=[*hosts, *extra_hosts])
    print(f"study {study.folder} ({len(study.participant_ids)} participants): open {study_url(url_host, port, token)}")
    if url_host != "127.0.0.1" and host not in LOOPBACK_HOSTS:
        print(f"  or, on this machine: {study_url('127.0.0.1', port, token)}")
    study.resume_closing()  # closed trials whose final update a stop or a kill cut off
    try:
        uvicorn.Server(uvicorn_config(app)).run(sockets=[sock])
    finally:
        sock.close()
        study.close()
        lock.release()
